"""What vcran still has to tell Orion: the latest value per robot and attribute (SPEC §7 coalescing).

The simulation thread puts; the sender thread takes a snapshot, sends it and, if Orion could not take it,
gives it back. Anything newer that arrived meanwhile wins over what is given back, so after an outage
Orion receives each robot's latest state once, not the backlog of every tick it missed. The outbox also
remembers the latest value of every attribute ever put, so that when Orion comes back without its data
(a restart of an in-memory broker, a wiped database) :meth:`resend_all` restores all of it.
"""

from __future__ import annotations

import threading

from vcran.messages import Message
from vcran.wire import Frame


class Outbox:
    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._pending: dict[str, dict[str, Message]] = {}
        self._latest: dict[str, dict[str, Message]] = {}
        self._frame: Frame | None = None

    def put(self, robot: str, attribute: str, message: Message) -> None:
        with self._lock:
            self._pending.setdefault(robot, {})[attribute] = message
            self._latest.setdefault(robot, {})[attribute] = message

    def resend_all(self) -> None:
        """Queue the latest value of every attribute again (newer pending values stay)."""
        with self._lock:
            for robot, attrs in self._latest.items():
                pending = self._pending.setdefault(robot, {})
                for attribute, message in attrs.items():
                    pending.setdefault(attribute, message)

    def put_frame(self, frame: Frame) -> None:
        with self._lock:
            self._frame = frame

    def take(self) -> tuple[dict[str, dict[str, Message]], Frame | None]:
        with self._lock:
            pending, frame = self._pending, self._frame
            self._pending, self._frame = {}, None
        return pending, frame

    def give_back(self, pending: dict[str, dict[str, Message]], frame: Frame | None) -> None:
        with self._lock:
            for robot, attrs in pending.items():
                newer = self._pending.setdefault(robot, {})
                for attribute, message in attrs.items():
                    newer.setdefault(attribute, message)
            if self._frame is None:
                self._frame = frame

    def __len__(self) -> int:
        with self._lock:
            return sum(map(len, self._pending.values())) + (self._frame is not None)
