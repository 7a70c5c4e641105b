"""SIGINT and SIGTERM as a request to stop, for the long-running commands (run, live, manage, send, broker).

Python's default turns SIGINT into a KeyboardInterrupt raised wherever the main thread happens to be:
inside orjson's ``default`` callback it surfaces as a TypeError (orjson wraps the callback's exception),
inside a file write it leaves a telemetry row half written. SIGTERM, unhandled, kills the process and the
contents of its output buffers. So within :class:`StopSignals` both only record the request (and call
``on_request``, which must be safe in a signal handler); the command stops at its next safe point and
finishes its outputs. A second signal means "now": it raises KeyboardInterrupt (exit 130, or 143 for
SIGTERM). The same signal again within :data:`REPEAT_WINDOW` of the first is not a second request but the
first delivered twice: ``timeout(1)`` sends its SIGTERM to the command and then to its own process group,
and a wrapper forwarding Ctrl-C to a child in the terminal's group does the same, so ``timeout 60 vcran
live ...`` sometimes (when the handler ran between the two) stopped at once, its outputs left incomplete.
Outside such a block, the CLI makes SIGTERM end any command as Ctrl-C does.

Exit codes (docs/live.md, docs/outputs.md): ``live``, ``manage`` and ``broker`` end this way normally and exit 0;
``run`` and ``send`` stopped early exit 128 + the signal number (130 for SIGINT, 143 for SIGTERM), as a
shell reports a process killed by it, so a script sees that the run did not finish.
"""

from __future__ import annotations

import signal
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from types import FrameType, TracebackType
from typing import Any

SIGNALS = (signal.SIGINT, signal.SIGTERM)
#: Seconds (monotonic, wall-clock) within which the same signal again is taken as the first delivered twice.
REPEAT_WINDOW = 1.0


class Terminated(KeyboardInterrupt):
    """SIGTERM outside a :class:`StopSignals` block: ends a command the way Ctrl-C does (exit 143)."""


@contextmanager
def terminate_like_interrupt() -> Iterator[None]:
    """SIGTERM raises :class:`Terminated` (the CLI's default for every command, restored afterwards)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def terminated(_signum: int, _frame: FrameType | None) -> None:
        raise Terminated

    previous = signal.signal(signal.SIGTERM, terminated)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


class StopSignals:
    def __init__(self, on_request: Callable[[], None] | None = None) -> None:
        self.on_request = on_request
        self.requested: int | None = None
        self._asked_at = 0.0
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> StopSignals:
        if threading.current_thread() is threading.main_thread():  # only the main thread may set handlers
            for signum in SIGNALS:
                self._previous[signum] = signal.signal(signum, self._handle)
        return self

    def __exit__(self, kind: type[BaseException] | None, value: BaseException | None, tb: TracebackType | None) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)
        self._previous.clear()

    def _handle(self, signum: int, _frame: FrameType | None) -> None:
        now = time.monotonic()
        if self.requested is not None:
            if signum == self.requested and now - self._asked_at < REPEAT_WINDOW:
                return  # the first one again (a process-group kill, timeout(1)): still a request to stop
            raise Terminated if signum == signal.SIGTERM else KeyboardInterrupt  # a second one: now
        self.requested, self._asked_at = signum, now
        if self.on_request is not None:
            self.on_request()

    @property
    def name(self) -> str:
        return signal.Signals(self.requested).name if self.requested is not None else ""

    @property
    def exit_code(self) -> int:
        """128 + the signal number, as a shell reports a process it ended."""
        return 128 + self.requested if self.requested is not None else 0
