"""What a side of the link still has to tell Orion (docs/contract.md §7 coalescing).

State attributes (``current_motion``, ``assignment_state``, ``ran_status``, ``robot_description``,
``battery_state``) are kept as the latest value per robot and attribute: after an outage Orion receives
each robot's latest state once, not the backlog of every tick it missed. The :data:`QUEUED` attributes are
different: each ``ran_error`` reports a distinct rejected input (docs/contract.md §2, "on each rejected input"), and
each command a fleet manager writes (``motion_assignment``, ...) is an input of its own, so they queue in
order and every one is kept until it is delivered or reported undeliverable, oldest first (a bounded
queue: past ``QUEUE_MAX`` waiting, the oldest are dropped and counted).

The simulation (or the manager's) thread puts; the sender thread takes a :class:`Batch`, sends it and, if
Orion could not take it, gives it back; anything newer that arrived meanwhile wins over what is given
back. The outbox also remembers the latest value of every state attribute, so that when Orion comes back
without its data (a restart of an in-memory broker, a wiped database) :meth:`resend_all` restores all of it.
A value is a message, or (a fleet manager's write) its NGSI JSON text, encoded when it was written.
"""

from __future__ import annotations

import threading
from collections import deque
from dataclasses import dataclass, field

from vcran.core.opil.messages import INBOUND, Message
from vcran.core.wire import Frame

QUEUE_MAX = 10_000
#: Attributes whose every value is delivered, in order: the RAN's errors and the fleet manager's commands.
QUEUED = frozenset({"ran_error", *INBOUND})

Value = Message | str  # a message, or NGSI JSON text


@dataclass(eq=False)
class Queued:
    """A queued value on its way to Orion; ``refusals`` counts the updates Orion refused as invalid
    content (400, 413, 422) while carrying it."""

    robot: str
    attribute: str
    value: Value
    refusals: int = 0


@dataclass
class Batch:
    state: dict[str, dict[str, Value]] = field(default_factory=dict)
    frame: Frame | None = None
    queued: list[Queued] = field(default_factory=list)

    def __bool__(self) -> bool:
        return bool(self.state or self.frame is not None or self.queued)


class Outbox:
    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._pending: dict[str, dict[str, Value]] = {}
        self._latest: dict[str, dict[str, Value]] = {}
        self._frame: Frame | None = None
        self._queue: deque[Queued] = deque()
        self._taken = False
        self.dropped = 0

    def put(self, robot: str, attribute: str, value: Value) -> None:
        with self._lock:
            if attribute in QUEUED:
                self._queue.append(Queued(robot, attribute, value))
                self._bound()
                return
            self._pending.setdefault(robot, {})[attribute] = value
            self._latest.setdefault(robot, {})[attribute] = value

    def put_frame(self, frame: Frame) -> None:
        with self._lock:
            self._frame = frame

    def resend_all(self) -> None:
        """Queue the latest value of every state attribute again (newer pending values stay)."""
        with self._lock:
            for robot, attrs in self._latest.items():
                pending = self._pending.setdefault(robot, {})
                for attribute, value in attrs.items():
                    pending.setdefault(attribute, value)

    @property
    def restorable(self) -> bool:
        """Whether :meth:`resend_all` has anything to restore: this side has published state."""
        with self._lock:
            return bool(self._latest)

    @property
    def idle(self) -> bool:
        """Nothing waits, and nothing taken is still on its way (:meth:`settle` not called yet)."""
        with self._lock:
            return not (self._taken or self._queue or self._frame is not None or any(self._pending.values()))

    def take(self) -> Batch:
        with self._lock:
            batch = Batch(self._pending, self._frame, list(self._queue))
            self._pending, self._frame = {}, None
            self._queue.clear()
            self._taken = True
        return batch

    def give_back(self, batch: Batch) -> None:
        with self._lock:
            for robot, attrs in batch.state.items():
                newer = self._pending.setdefault(robot, {})
                for attribute, value in attrs.items():
                    newer.setdefault(attribute, value)
            if self._frame is None:
                self._frame = batch.frame
            self._queue.extendleft(reversed(batch.queued))  # older than anything put meanwhile
            self._bound()

    def settle(self) -> None:
        """What :meth:`take` took has been delivered, refused or given back."""
        with self._lock:
            self._taken = False

    def _bound(self) -> None:
        while len(self._queue) > QUEUE_MAX:
            self._queue.popleft()
            self.dropped += 1
