"""The progress line of a sweep (docs/contract.md §10): runs done of all, failures, ETA from the mean wall time per run;
whole lines at most every 10 s in a log."""

from __future__ import annotations

import io

from tests.conftest import HandClock
from vcran.sweep.progress import Progress


def test_a_log_gets_a_line_every_ten_seconds_with_the_eta_of_the_runs_left():
    stream, clock = io.StringIO(), HandClock()
    progress = Progress(stream, 10, clock=clock)
    clock.now = 5.0
    progress.update(failed=False)
    assert stream.getvalue() == ""  # not yet 10 s
    clock.now = 12.0
    progress.update(failed=True)
    # 2 runs in 12 s: 6 s each, 8 left -> 48 s
    assert stream.getvalue() == "2/10 runs, 1 failed, ETA 48 s, 12 s elapsed\n"
    clock.now = 13.0
    progress.update(failed=False)
    assert stream.getvalue().count("\n") == 1  # the next line is due 10 s after the last


def test_long_durations_read_as_minutes_and_hours_and_quiet_prints_nothing():
    stream, clock = io.StringIO(), HandClock()
    progress = Progress(stream, 4000, "examples", clock=clock)
    progress.done = 1000
    assert progress.render(75.0) == "1,000/4,000 examples, 0 failed, ETA 3:45, 1:15 elapsed"
    progress.done = 1
    assert progress.render(1.0).endswith("ETA 1:06:39, 1 s elapsed")
    quiet = Progress(stream, 3, quiet=True, clock=clock)
    clock.now = 100.0
    quiet.update(failed=False)
    assert stream.getvalue() == ""
