"""Progress bar and live status line (issue 6): on a terminal only, throttled, and invisible to the outputs."""

from __future__ import annotations

import io
import os
from pathlib import Path

import pytest

from tests.conftest import ROOT, HandClock
from transports.scripted import ScriptedTransport
from vcran.cli import main
from vcran.io import progress as progress_module
from vcran.io.progress import LiveStatus, ProgressBar, StatusLine, Throttle, progress_bar
from vcran.io.scenario_file import load
from vcran.runner import run_to

DEMO = ROOT / "scenarios" / "demo.toml"


class FakeTerminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_no_bar_unless_the_stream_is_a_terminal_and_not_quiet() -> None:
    assert progress_bar(io.StringIO(), 60.0) is None
    read, write = os.pipe()
    with os.fdopen(write, "w") as pipe:
        assert progress_bar(pipe, 60.0) is None
    os.close(read)
    assert progress_bar(FakeTerminal(), 60.0, quiet=True) is None
    assert isinstance(progress_bar(FakeTerminal(), 60.0), ProgressBar)


def test_vcran_run_writes_nothing_extra_to_a_non_terminal_stderr(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(progress_module, "REDRAW_INTERVAL", 0.0)  # a terminal would get a redraw every second
    assert main(["run", str(DEMO), "--out", str(tmp_path)]) == 0
    captured = capsys.readouterr()
    assert captured.err == "" and "\r" not in captured.out


def test_vcran_run_draws_the_bar_on_a_terminal_and_clears_it(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    terminal = FakeTerminal()
    monkeypatch.setattr(progress_module, "REDRAW_INTERVAL", 0.0)
    monkeypatch.setattr("sys.stderr", terminal)
    assert main(["run", str(DEMO), "--out", str(tmp_path)]) == 0
    text = terminal.getvalue()
    # A redraw per telemetry tick, 0 s to 57 s (the demo ends there, of its 600 s duration), then the
    # line is wiped so that the summary on stdout starts on a clean line.
    assert text.count("\r[") == 58
    assert "\r[##......................]  10% 57/600 s, " in text and "x real time, 3 tasks done\r " in text
    assert text.endswith("\r")
    assert "\r" not in capsys.readouterr().out


def test_quiet_silences_the_bar_on_a_terminal(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    terminal = FakeTerminal()
    monkeypatch.setattr(progress_module, "REDRAW_INTERVAL", 0.0)
    monkeypatch.setattr("sys.stderr", terminal)
    assert main(["run", str(DEMO), "--out", str(tmp_path), "--quiet"]) == 0
    assert terminal.getvalue() == ""


def test_progress_callback_sees_the_run_and_changes_nothing(tmp_path: Path) -> None:
    scenario = load(DEMO)
    seen: list[tuple[float, int]] = []
    run_to(scenario, tmp_path / "watched", ScriptedTransport(scenario.messages()),
           progress=lambda t, n: seen.append((t, n)))
    run_to(scenario, tmp_path / "plain", ScriptedTransport(scenario.messages()))
    assert [t for t, _ in seen] == [float(k) for k in range(58)]  # every telemetry tick, to the end at 57 s
    done = [n for t, n in seen]  # tasks 100, 200 and 300 complete at 18.4, 38.5 and 56.3 s
    assert done[18:20] == [0, 1] and done[38:40] == [1, 2] and done[56:] == [2, 3]
    for name in ("events.jsonl.zst", "trace.jsonl.zst", "legs.npy", "summary.json"):
        assert (tmp_path / "watched" / name).read_bytes() == (tmp_path / "plain" / name).read_bytes()


def test_bar_redraws_at_most_once_per_interval_and_renders_its_figures() -> None:
    clock, terminal = HandClock(100.0), FakeTerminal()
    bar = ProgressBar(terminal, 100.0, min_interval=0.2, clock=clock)
    bar(10.0, 1)
    assert terminal.getvalue() == ""  # not before one interval: a short run shows nothing
    clock.now += 0.25
    bar(50.0, 7)
    shown = "[############............]  50% 50/100 s, 200x real time, 7 tasks done"
    assert terminal.getvalue() == "\r" + shown
    clock.now += 0.1
    bar(60.0, 8)
    assert terminal.getvalue().count("\r") == 1
    bar.close()
    assert terminal.getvalue() == "\r" + shown + "\r" + " " * len(shown) + "\r"


def test_bar_without_duration_shows_time_only() -> None:
    bar = ProgressBar(FakeTerminal(), None, clock=HandClock(100.0))
    assert bar.render(3600.0, 12, 2.0) == "3,600 s simulated, 1,800x real time, 12 tasks done"


def test_throttle() -> None:
    clock = HandClock(100.0)
    due = Throttle(1.0, clock)
    ticks = []
    for _ in range(30):
        clock.now += 0.25
        ticks.append(due())
    assert sum(ticks) == 7 and ticks[3] is True and ticks[:3] == [False] * 3


STATUS = LiveStatus(t=125.25, robots=10, tasks_done=1234, transport="orion ok",
                    states={"WAITING": 3, "MOTION": 6, "ACTION": 1})


def test_live_status_renders_every_state_in_order() -> None:
    assert STATUS.render() == (
        "t 125.2 s | 10 robots: WAITING 3 TASK 0 MOTION 6 ACTION 1 | tasks done 1,234 | orion ok"
    )


def test_live_status_of_a_vda5050_fleet_shows_its_own_states() -> None:
    """vcran live --mqtt's vehicles are idle, driving, working or paused (vcran/commands/_live_mqtt.py), none of
    RanLogic's states."""
    status = LiveStatus(t=3.0, robots=2, tasks_done=0, transport="MQTT ...", states={"driving": 2},
                        names=("idle", "driving", "working", "paused"))
    assert status.render() == "t 3.0 s | 2 robots: idle 0 driving 2 working 0 paused 0 | tasks done 0 | MQTT ..."


def test_status_line_rewrites_in_place_on_a_terminal(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", "40")
    clock, terminal = HandClock(100.0), FakeTerminal()
    line = StatusLine(terminal, min_interval=0.25, clock=clock)
    clock.now += 0.3
    line.update(STATUS)
    assert terminal.getvalue() == "\r" + STATUS.render()[:39]  # cut to the terminal, or it would wrap
    line.update(STATUS)  # too soon: nothing
    clock.now += 0.3
    line.update(LiveStatus(t=126.0, robots=10, tasks_done=1, transport="orion down"))
    assert terminal.getvalue().count("\r") == 2 and "\n" not in terminal.getvalue()
    line.close()
    assert terminal.getvalue().endswith(" \r")


def test_status_line_writes_whole_lines_elsewhere_and_seldom() -> None:
    clock, log = HandClock(100.0), io.StringIO()
    line = StatusLine(log, log_interval=10.0, clock=clock)
    for _ in range(40):  # 40 updates over 20 s
        clock.now += 0.5
        line.update(STATUS)
    line.close()
    assert log.getvalue() == (STATUS.render() + "\n") * 2
