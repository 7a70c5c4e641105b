"""What a long run shows a person while it runs: a progress bar (``vcran run``) and a live status line (``vcran live``).

Both write one line that is rewritten in place with ``\\r``, which only makes sense on a terminal: piped
into a file or a CI log the bar would be hundreds of garbled lines. So the bar exists only when its
stream is a terminal, and the status line falls back to whole lines, at a slow rate, elsewhere.
Redrawing is limited to a few times per wall second, whatever rate the caller updates at, so a fast
simulation pays one clock read per update and nothing more. Wall-clock figures appear only here, never in
a run's output files (docs/contract.md §5).
"""

from __future__ import annotations

import shutil
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TextIO

from vcran.core.opil.effects import State

Clock = Callable[[], float]

STATES = tuple(s.value for s in State)
#: Wall seconds between two redraws of the progress bar: a few a second reads as live and costs nothing.
REDRAW_INTERVAL = 0.2


def is_terminal(stream: TextIO) -> bool:
    isatty = getattr(stream, "isatty", None)
    return bool(isatty and isatty())


class Throttle:
    """True at most once per ``interval`` wall seconds, the first time one interval after creation:
    a run shorter than that shows nothing at all."""

    def __init__(self, interval: float, clock: Clock = time.monotonic) -> None:
        self.interval, self.clock = interval, clock
        self._next = clock() + interval

    def __call__(self) -> bool:
        now = self.clock()
        if now < self._next:
            return False
        self._next = now + self.interval
        return True


class InPlaceLine:
    """One terminal line, rewritten in place and cut to the terminal's width (a wrapped line cannot be)."""

    def __init__(self, stream: TextIO) -> None:
        self.stream = stream
        self._shown = 0

    def show(self, text: str) -> None:
        text = text[: max(shutil.get_terminal_size().columns - 1, 20)]
        self.stream.write("\r" + text + " " * max(self._shown - len(text), 0))
        self.stream.flush()
        self._shown = len(text)

    def clear(self) -> None:
        """Wipe the line, so that what is printed next starts at the left margin of a clean line."""
        if self._shown:
            self.stream.write("\r" + " " * self._shown + "\r")
            self.stream.flush()
            self._shown = 0


class ProgressBar:
    """``vcran run``'s bar: simulated time against the scenario's duration, speed factor, tasks done.

    Call it as the model's ``progress`` callback, with (simulated time, tasks completed so far);
    :meth:`close` when the run ends. Without a duration (a
    run that stops when idle) it shows the simulated time and no bar.
    """

    WIDTH = 24

    def __init__(self, stream: TextIO, duration: float | None, *, min_interval: float | None = None,
                 clock: Clock = time.monotonic) -> None:
        self.duration = duration
        self.clock = clock
        self.started = clock()
        self.due = Throttle(REDRAW_INTERVAL if min_interval is None else min_interval, clock)
        self.line = InPlaceLine(stream)

    def __call__(self, now: float, tasks_done: int) -> None:
        if self.due():
            self.line.show(self.render(now, tasks_done, self.clock() - self.started))

    def render(self, now: float, tasks_done: int, wall: float) -> str:
        speed = f"{now / wall:,.0f}x" if wall > 0 else "-"
        text = f"{now:,.0f} s simulated, {speed} real time, {tasks_done:,} tasks done"
        if not self.duration:
            return text
        share = min(max(now / self.duration, 0.0), 1.0)
        filled = round(share * self.WIDTH)
        return f"[{'#' * filled}{'.' * (self.WIDTH - filled)}] {share:4.0%} {now:,.0f}/{self.duration:,.0f} s, " \
               f"{speed} real time, {tasks_done:,} tasks done"

    def close(self) -> None:
        self.line.clear()


def progress_bar(stream: TextIO, duration: float | None, quiet: bool = False) -> ProgressBar | None:
    """A bar on ``stream`` if it is a terminal and the user did not ask for quiet; else none at all."""
    return ProgressBar(stream, duration) if is_terminal(stream) and not quiet else None


@dataclass(frozen=True, slots=True)
class LiveStatus:
    """A live run at one instant: what ``vcran live`` reports on its status line."""

    t: float  # simulated seconds
    robots: int
    tasks_done: int
    transport: str  # the transport's health in its own words, e.g. "orion ok", "orion down 12 s, 40 queued"
    states: Mapping[str, int] = field(default_factory=dict)  # the logic's state -> robots in it
    #: The states always shown, zero or not: RanLogic's (OPIL); a VDA 5050 fleet names its own.
    names: tuple[str, ...] = STATES

    def render(self) -> str:
        states = " ".join(f"{name} {self.states.get(name, 0)}" for name in self.names)
        others = " ".join(f"{name} {n}" for name, n in sorted(self.states.items()) if name not in self.names)
        return (f"t {self.t:,.1f} s | {self.robots} robots: {states}{' ' + others if others else ''} | "
                f"tasks done {self.tasks_done:,} | {self.transport}")


class StatusLine:
    """Shows :class:`LiveStatus` updates: in place on a terminal, as whole lines anywhere else.

    A log gets a line at most every ``log_interval`` wall seconds (default 10), a terminal a redraw at
    most every ``min_interval`` (default 0.25): a live run updates every simulated second, forever.
    """

    def __init__(self, stream: TextIO, *, min_interval: float = 0.25, log_interval: float = 10.0,
                 clock: Clock = time.monotonic) -> None:
        self.stream = stream
        self.tty = is_terminal(stream)
        self.due = Throttle(min_interval if self.tty else log_interval, clock)
        self.line = InPlaceLine(stream)

    def update(self, status: LiveStatus) -> None:
        if not self.due():
            return
        if self.tty:
            self.line.show(status.render())
        else:
            self.stream.write(status.render() + "\n")
            self.stream.flush()

    def close(self) -> None:
        if self.tty:
            self.line.clear()
