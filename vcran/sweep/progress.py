"""The progress line of a sweep or a fuzz campaign: runs done of all, failures, ETA.

On a terminal one line rewritten in place a few times a second; in a pipe or a CI log a whole line every
ten wall seconds (:mod:`vcran.io.progress`, whose pieces it reuses). Wall-clock figures stay here, on
the screen, never in the runs table's deterministic columns.
"""

from __future__ import annotations

import time
from typing import TextIO

from vcran.io.progress import REDRAW_INTERVAL, Clock, InPlaceLine, Throttle, is_terminal

#: Wall seconds between two lines of the progress when it goes to a log rather than a terminal.
LOG_INTERVAL = 10.0


class Progress:
    def __init__(self, stream: TextIO, total: int, what: str = "runs", *, quiet: bool = False,
                 clock: Clock = time.monotonic) -> None:
        self.stream, self.total, self.what, self.clock = stream, total, what, clock
        self.quiet = quiet
        self.tty = is_terminal(stream)
        self.started = clock()
        self.due = Throttle(REDRAW_INTERVAL if self.tty else LOG_INTERVAL, clock)
        self.line = InPlaceLine(stream)
        self.done = self.failed = 0

    def update(self, failed: bool, count: int = 1) -> None:
        self.done += count
        self.failed += failed
        if self.quiet or not self.due():
            return
        text = self.render(self.clock() - self.started)
        if self.tty:
            self.line.show(text)
        else:
            self.stream.write(text + "\n")
            self.stream.flush()

    def render(self, wall: float) -> str:
        text = f"{self.done:,}/{self.total:,} {self.what}, {self.failed:,} failed"
        if 0 < self.done < self.total:
            text += f", ETA {_duration(wall / self.done * (self.total - self.done))}"
        return text + f", {_duration(wall)} elapsed"

    def close(self) -> None:
        if self.tty:
            self.line.clear()


def _duration(seconds: float) -> str:
    seconds = round(seconds)
    if seconds < 60:
        return f"{seconds} s"
    minutes, seconds = divmod(seconds, 60)
    if minutes < 60:
        return f"{minutes}:{seconds:02d}"
    hours, minutes = divmod(minutes, 60)
    return f"{hours}:{minutes:02d}:{seconds:02d}"
