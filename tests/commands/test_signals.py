"""SIGINT and SIGTERM stop run, live, send and broker cleanly (issue 12 item 9, docs/outputs.md, docs/live.md).

Each command runs as its own process, as a user starts it; the signal comes while it works. "Cleanly":
no traceback, the outputs complete (end record, summary, whole telemetry rows) so that a replay
reproduces them, and the documented exit code: 128 + the signal for run and send stopped early, 0 for
live and broker, whose normal end this is.
"""

from __future__ import annotations

import json
import signal
import time

import numpy as np
import pytest

from tests.conftest import HandClock, read_lines
from tests.transports.test_live import DEMO, broker_process, vcran, wait_until  # noqa: F401 - a fixture
from vcran.cli import main
from vcran.commands._signals import REPEAT_WINDOW, StopSignals, Terminated
from vcran.io.gen import generate


def finished_outputs(out) -> dict:
    """The outputs of a run that stopped cleanly; returns its summary."""
    lines = read_lines(out / "trace.jsonl.zst")
    assert json.loads(lines[-1])["dir"] == "end"
    legs = np.load(out / "legs.npy")  # closed properly: its header counts every row written
    assert (out / "legs.npy").stat().st_size == 512 + legs.nbytes
    return json.loads((out / "summary.json").read_text())


@pytest.mark.slow
@pytest.mark.parametrize("signum, code, delay", [(signal.SIGINT, 130, 0.3), (signal.SIGINT, 130, 0.7),
                                                 (signal.SIGTERM, 143, 0.5)])
def test_run_stops_at_a_signal_with_complete_outputs(tmp_path, signum, code, delay):
    scenario = tmp_path / "fleet.toml"
    scenario.write_text(generate(100, 2.0, 1))  # ~10 s of work: the signal lands mid-run
    out = tmp_path / "out"
    proc = vcran("run", str(scenario), "--out", str(out), "--quiet")
    assert wait_until(lambda: (tmp_path / "out.incomplete" / "trace.jsonl.zst").exists(), 20)  # under way
    time.sleep(delay)  # into the run: orjson's callbacks, file writes
    proc.send_signal(signum)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == code, stderr
    assert "Traceback" not in stderr and f"stopped by {signal.Signals(signum).name}" in stderr
    summary = finished_outputs(out)
    assert 0 < summary["sim_time"] < 7200.0
    assert main(["replay", str(out), "--out", str(tmp_path / "rep"), "--verify", "--quiet"]) == 0


@pytest.fixture
def clock(monkeypatch):
    c = HandClock(1000.0)
    monkeypatch.setattr("vcran.commands._signals.time.monotonic", c)
    return c


@pytest.mark.parametrize(("signum", "raised"), [(signal.SIGINT, KeyboardInterrupt), (signal.SIGTERM, Terminated)])
def test_a_second_signal_stops_at_once(signum, raised, clock):
    """The safety net when the safe point never comes (an instant that never ends, as a random fault
    source with mtbf = 1e-300 made before the loader refused it): the first signal only asks, the second
    raises at once, whatever the run is doing (exit 130 or 143, docs/outputs.md)."""
    asked, before = [], signal.getsignal(signum)
    with pytest.raises(raised), StopSignals(lambda: asked.append(1)) as signals:
        signal.raise_signal(signum)
        assert (signals.requested, asked) == (signum, [1])  # asked, nothing raised
        clock.now += REPEAT_WINDOW
        signal.raise_signal(signum)
        pytest.fail("the second signal did not stop it")
    assert signal.getsignal(signum) is before  # the handlers are given back


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_one_signal_delivered_twice_is_one_request(signum, clock):
    """``timeout 60 vcran live ...``: timeout(1) sends SIGTERM to vcran and then to its process group, so vcran
    can see it twice, microseconds apart; taken as "stop now", the run ended "interrupted" with its outputs
    left in DIR.incomplete (found by a fresh-user review). The same signal within REPEAT_WINDOW is the first
    one again; another signal, even at once, is a second request."""
    asked = []
    with StopSignals(lambda: asked.append(1)) as signals:
        signal.raise_signal(signum)
        clock.now += REPEAT_WINDOW / 2
        signal.raise_signal(signum)  # the same request: nothing raised, not asked again
        assert (signals.requested, asked) == (signum, [1])
        other = signal.SIGTERM if signum == signal.SIGINT else signal.SIGINT
        with pytest.raises(KeyboardInterrupt):
            signal.raise_signal(other)


def test_live_ends_normally_on_sigterm(broker_process, tmp_path):  # noqa: F811 - the fixture
    out = tmp_path / "live"
    live = vcran("live", str(DEMO), "--orion", broker_process, "--out", str(out), "--factor", "20", "--quiet")
    assert wait_until(lambda: (tmp_path / "live.incomplete" / "trace.jsonl.zst").exists(), 20)
    time.sleep(1.0)  # x20: some 20 simulated seconds
    live.send_signal(signal.SIGTERM)
    _, stderr = live.communicate(timeout=30)
    assert live.returncode == 0 and "Traceback" not in stderr, stderr
    assert finished_outputs(out)["sim_time"] > 0
    assert main(["replay", str(out), "--out", str(tmp_path / "rep"), "--verify", "--quiet"]) == 0


def test_send_stops_between_messages_on_sigterm(broker_process, tmp_path):  # noqa: F811 - the fixture
    assert main(["orion", "init", str(DEMO), "--orion", broker_process]) == 0
    send = vcran("send", str(DEMO), "--orion", broker_process, "--factor", "0.5")  # seconds between messages
    first = send.stdout.readline()
    assert first.startswith("t="), first + send.stderr.read()
    send.send_signal(signal.SIGTERM)
    stdout, stderr = send.communicate(timeout=10)
    assert send.returncode == 143, stderr
    assert "Traceback" not in stderr and "vcran send: stopped by SIGTERM: sent 1 message(s), 0 failed" in stderr


def test_broker_ends_normally_on_sigterm():
    from tests.transports.test_live import free_port

    proc = vcran("broker", "--port", str(free_port()))
    assert "listening" in proc.stdout.readline()
    proc.send_signal(signal.SIGTERM)
    _, stderr = proc.communicate(timeout=10)
    assert proc.returncode == 0 and "Traceback" not in stderr, stderr


def test_sigterm_ends_any_other_command_like_ctrl_c():
    # vcran gen of a huge fleet is busy long enough to be signalled; no handler of its own
    proc = vcran("gen", "--robots", "20000", "--hours", "50", "--seed", "1")
    time.sleep(1.0)
    proc.send_signal(signal.SIGTERM)
    _, stderr = proc.communicate(timeout=20)
    assert proc.returncode == 143 and stderr.strip().endswith("vcran gen: interrupted"), stderr


def test_a_ctrl_c_inside_orjsons_callback_is_an_interruption_not_a_type_error(monkeypatch, capsys):
    """Commands without a stop handler of their own (replay, fuzz) write through orjson too; a
    KeyboardInterrupt raised inside its ``default`` callback comes out as a TypeError."""
    import orjson

    from vcran.commands import run as run_command

    def interrupted_in_orjson(args):
        def default(_value):
            raise KeyboardInterrupt

        orjson.dumps(object(), default=default)

    monkeypatch.setattr(run_command, "run", interrupted_in_orjson)
    assert main(["run", str(DEMO), "--out", "unused"]) == 130
    assert capsys.readouterr().err == "vcran run: interrupted\n"
