"""What vcran still has to tell Orion (SPEC §7 coalescing).

State attributes (``current_motion``, ``assignment_state``, ``ran_status``, ``robot_description``, ``battery_state``) are
kept as the latest value per robot and attribute: after an outage Orion receives each robot's latest
state once, not the backlog of every tick it missed. ``ran_error`` is different: each one reports a
distinct rejected input (SPEC §2, "on each rejected input"), so errors queue in order and every one is
kept until it is delivered or reported undeliverable, oldest first (a bounded queue: past ``ERRORS_MAX``
pending errors the oldest are dropped and counted).

The simulation thread puts; the sender thread takes a :class:`Batch`, sends it and, if Orion could not
take it, gives it back; anything newer that arrived meanwhile wins over what is given back. The outbox
also remembers the latest value of every state attribute, so that when Orion comes back without its data
(a restart of an in-memory broker, a wiped database) :meth:`resend_all` restores all of it.
"""

from __future__ import annotations

import threading
from collections import deque
from dataclasses import dataclass, field

from vcran.core.messages import Message
from vcran.core.wire import Frame

ERRORS_MAX = 10_000


@dataclass(eq=False)
class PendingError:
    """A ``ran_error`` on its way to Orion; ``refusals`` counts the updates Orion refused as invalid
    content (400, 413, 422) while carrying it."""

    robot: str
    message: Message
    refusals: int = 0


@dataclass
class Batch:
    state: dict[str, dict[str, Message]] = field(default_factory=dict)
    frame: Frame | None = None
    errors: list[PendingError] = field(default_factory=list)

    def __bool__(self) -> bool:
        return bool(self.state or self.frame is not None or self.errors)


class Outbox:
    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._pending: dict[str, dict[str, Message]] = {}
        self._latest: dict[str, dict[str, Message]] = {}
        self._frame: Frame | None = None
        self._errors: deque[PendingError] = deque()
        self.errors_dropped = 0

    def put(self, robot: str, attribute: str, message: Message) -> None:
        with self._lock:
            if attribute == "ran_error":
                if len(self._errors) >= ERRORS_MAX:
                    self._errors.popleft()
                    self.errors_dropped += 1
                self._errors.append(PendingError(robot, message))
                return
            self._pending.setdefault(robot, {})[attribute] = message
            self._latest.setdefault(robot, {})[attribute] = message

    def put_frame(self, frame: Frame) -> None:
        with self._lock:
            self._frame = frame

    def resend_all(self) -> None:
        """Queue the latest value of every state attribute again (newer pending values stay)."""
        with self._lock:
            for robot, attrs in self._latest.items():
                pending = self._pending.setdefault(robot, {})
                for attribute, message in attrs.items():
                    pending.setdefault(attribute, message)

    def take(self) -> Batch:
        with self._lock:
            batch = Batch(self._pending, self._frame, list(self._errors))
            self._pending, self._frame = {}, None
            self._errors.clear()
        return batch

    def give_back(self, batch: Batch) -> None:
        with self._lock:
            for robot, attrs in batch.state.items():
                newer = self._pending.setdefault(robot, {})
                for attribute, message in attrs.items():
                    newer.setdefault(attribute, message)
            if self._frame is None:
                self._frame = batch.frame
            self._errors.extendleft(reversed(batch.errors))  # older than anything put meanwhile
            while len(self._errors) > ERRORS_MAX:
                self._errors.popleft()
                self.errors_dropped += 1
