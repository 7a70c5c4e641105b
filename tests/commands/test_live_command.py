"""``vcran live``'s two edges (docs/contract.md §7, §11): ``--orion URL`` for an OPIL scenario, ``--mqtt URL`` for a
VDA 5050 one, exactly one of them. Every mismatch is one line and exit 2, before anything is connected to
or any folder made: each case here points the command at a listening socket that must never be called, and
at an output folder that must never appear. (A run itself: tests/transports/mqtt/test_live_mqtt.py.)"""

from __future__ import annotations

import socket
from collections.abc import Iterator
from dataclasses import replace
from datetime import UTC, datetime, timedelta, timezone

import pytest

import vcran
from vcran.cli import main
from vcran.commands.live import on_wall_clock


@pytest.fixture
def listener() -> Iterator[socket.socket]:
    """A TCP port that listens and must never get a connection."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        s.setblocking(False)
        yield s


def never_called(listener: socket.socket) -> bool:
    try:
        listener.accept()[0].close()
    except BlockingIOError:
        return True
    return False


@pytest.mark.parametrize(("argv", "message"), [
    (["vda5050", "--orion", "ORION"], "vda5050.toml: [simulation] protocol = 'vda5050': its robots go live with "
                                      "--mqtt URL, not --orion"),
    (["demo", "--mqtt", "MQTT"], "demo.toml: [simulation] protocol = 'opil': its robots go live with --orion URL, "
                                 "not --mqtt"),
    (["vda5050"], "one of the arguments --mqtt --orion is required"),
    (["vda5050", "--mqtt", "MQTT", "--orion", "ORION"], "argument --orion: not allowed with argument --mqtt"),
    (["vda5050", "--mqtt", "mqtts://127.0.0.1:8883"], "--mqtt 'mqtts://127.0.0.1:8883': TLS (mqtts://) is not supported"),
    (["vda5050", "--mqtt", "http://127.0.0.1:1883"], "--mqtt 'http://127.0.0.1:1883': the scheme must be mqtt://"),
    (["vda5050", "--mqtt", "MQTT", "--notify-url", "http://127.0.0.1:8765/n", "--poll-interval", "1"],
     "--notify-url, --poll-interval: only with --orion (--mqtt has none of them)"),
    (["vda5050", "--mqtt", "MQTT", "--service", "plant"], "--service: only with --orion"),
    (["vda5050", "--mqtt", "MQTT", "--factor", "inf"], "--factor must be a finite number above 0, got inf"),
])
def test_a_scenario_goes_live_on_its_protocols_edge_only(argv, message, listener, tmp_path, capsys):
    port = listener.getsockname()[1]
    urls = {"ORION": f"http://127.0.0.1:{port}", "MQTT": f"mqtt://127.0.0.1:{port}"}
    out = tmp_path / "out"
    assert main(["live", *[urls.get(a, a) for a in argv], "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("vcran live: ") and err.count("\n") == 1, err
    assert message in err, err
    assert never_called(listener)
    assert list(tmp_path.iterdir()) == []


def test_a_broker_that_cannot_be_reached_is_one_line_and_no_folder(tmp_path, capsys, monkeypatch):
    """Nothing listens on the port: the vehicles cannot connect within the wait (shortened here), every
    connection is closed again and the command ends with one line (exit 2), no run folder made."""
    monkeypatch.setattr("vcran.commands._live_mqtt.CONNECT_TIMEOUT", 0.5)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # bound, not listening: connections are refused
        assert main(["live", "vda5050", "--mqtt", f"mqtt://127.0.0.1:{port}", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err == (f"vcran live: cannot connect to the broker: mqtt://127.0.0.1:{port}: not connected after 0.5 s "
                   f"(cannot reach the broker at mqtt://127.0.0.1:{port})\n")
    assert list(tmp_path.iterdir()) == []


def test_a_live_vda5050_run_is_on_the_wall_clock_unless_its_scenario_has_a_calendar() -> None:
    """``on_wall_clock`` (vcran live --mqtt, vcran manage --mqtt): a VDA 5050 scenario without ``[simulation]
    epoch`` gets the wall clock at the start, UTC, cut to the millisecond (21:30:12.3456789 is .345, never
    the later .346); one that sets its own keeps it; an OPIL scenario, which has no calendar, is left as it is."""
    at = datetime(2026, 11, 27, 21, 30, 12, 345_678, tzinfo=UTC)
    vda = vcran.load_scenario("vda5050")
    assert vda.settings.epoch is None
    live = on_wall_clock(vda, at)
    assert live.settings.epoch == "2026-11-27T21:30:12.345Z"
    assert live == replace(vda, settings=replace(vda.settings, epoch="2026-11-27T21:30:12.345Z"))  # nothing else
    east = datetime(2026, 11, 27, 22, 30, 12, 345_678, tzinfo=timezone(timedelta(hours=1)))
    assert on_wall_clock(vda, east).settings.epoch == "2026-11-27T21:30:12.345Z"  # the same instant, in UTC
    own = replace(vda, settings=replace(vda.settings, epoch="2026-01-01T00:00:00Z"))
    assert on_wall_clock(own, at) is own
    demo = vcran.load_scenario("demo")
    assert on_wall_clock(demo, at) is demo
    now = on_wall_clock(vda).settings.epoch  # the wall clock itself: a real instant, not 1970's
    assert now is not None and abs(datetime.fromisoformat(now) - datetime.now(UTC)) < timedelta(hours=1)


def test_the_commands_wait_for_the_broker_as_long_as_the_edge_does():
    """vcran live --mqtt (and manage, which reads the same constant) waits the MQTT edge's own connect timeout;
    the command keeps a copy only so that it imports paho when it connects (docs/contract.md §11)."""
    from transports.mqtt.client import CONNECT_TIMEOUT
    from vcran.commands import _live_mqtt

    assert _live_mqtt.CONNECT_TIMEOUT == CONNECT_TIMEOUT
