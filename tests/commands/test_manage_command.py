"""``vcran manage``'s two edges (docs/contract.md §9, §11): ``--orion URL`` for an OPIL scenario and its fleet manager,
``--mqtt URL`` for a VDA 5050 one and its master, exactly one of them. Every mismatch is one line and exit 2,
before anything is connected to or any folder made: each case points the command at a listening socket that
must never be called, and at an output folder that must never appear. (Runs: tests/transports/test_manage.py
over Orion, tests/transports/mqtt/test_manage_mqtt.py over MQTT.)"""

from __future__ import annotations

import socket

import pytest

from tests.commands.test_live_command import listener, never_called  # noqa: F401 - the fixture
from vcran.cli import main

DISPATCHER, MASTER = "vcran.managers.dispatcher:Dispatcher", "vcran.managers.vda5050:MasterControl"


@pytest.mark.parametrize(("argv", "message"), [
    (["vda5050-warehouse", "--orion", "ORION"], "vda5050-warehouse.toml: [simulation] protocol = 'vda5050': its robots "
                                                "are managed with --mqtt URL, not --orion"),
    (["warehouse", "--mqtt", "MQTT"], "warehouse.toml: [simulation] protocol = 'opil': its robots are managed with "
                                      "--orion URL, not --mqtt"),
    (["vda5050-warehouse"], "one of the arguments --mqtt --orion is required"),
    (["vda5050-warehouse", "--mqtt", "MQTT", "--orion", "ORION"], "argument --orion: not allowed with argument --mqtt"),
    (["vda5050-warehouse", "--mqtt", "http://127.0.0.1:1883"], "--mqtt 'http://127.0.0.1:1883': the scheme must be mqtt://"),
    (["vda5050-warehouse", "--mqtt", "MQTT", "--notify-url", "http://127.0.0.1:8765/n"],
     "--notify-url: only with --orion (--mqtt has none of them)"),
    (["vda5050-warehouse", "--mqtt", "MQTT", "--poll-interval", "1"], "--poll-interval: only with --orion"),
    (["vda5050-warehouse", "--mqtt", "MQTT", "--manager", DISPATCHER],
     "fleet manager vcran.managers.dispatcher:Dispatcher is an OPIL fleet manager (vcran.FleetManager); this "
     "scenario's robots speak VDA 5050"),
    (["warehouse", "--orion", "ORION", "--manager", MASTER],
     "fleet manager vcran.managers.vda5050:MasterControl is a VDA 5050 master (vcran.core.vda5050.master.Master); "
     "this scenario's robots speak OPIL"),
    (["vda5050", "--mqtt", "MQTT"], "names no fleet manager: give one with --manager module:Class"),
    (["vda5050-warehouse", "--mqtt", "MQTT", "--jobs", "-1"], "--jobs must not be negative"),
    (["warehouse", "--orion", "ORION", "--listen", "0.0.0.0"], "--listen is where the notification listener binds"),
])
def test_a_fleet_manager_goes_live_on_its_protocols_edge_only(argv, message, listener, tmp_path, capsys):  # noqa: F811
    port = listener.getsockname()[1]
    urls = {"ORION": f"http://127.0.0.1:{port}", "MQTT": f"mqtt://127.0.0.1:{port}"}
    out = tmp_path / "out"
    assert main(["manage", *[urls.get(a, a) for a in argv], "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("vcran manage: ") and err.count("\n") == 1, err
    assert message in err, err
    assert never_called(listener)
    assert list(tmp_path.iterdir()) == []


def test_a_broker_that_cannot_be_reached_is_one_line_and_no_folder(tmp_path, capsys, monkeypatch):
    """Nothing listens on the port: the master cannot connect within the wait (shortened here, the same as
    vcran live --mqtt's), the command ends with one line (exit 2) before the master starts, no run folder made."""
    monkeypatch.setattr("vcran.commands._live_mqtt.CONNECT_TIMEOUT", 0.5)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # bound, not listening: connections are refused
        code = main(["manage", "vda5050-warehouse", "--mqtt", f"mqtt://127.0.0.1:{port}", "--out", str(tmp_path / "out")])
    assert code == 2
    err = capsys.readouterr().err
    assert err == (f"vcran manage: cannot connect to the broker: mqtt://127.0.0.1:{port}: not connected after 0.5 s "
                   f"(cannot reach the broker at mqtt://127.0.0.1:{port})\n")
    assert list(tmp_path.iterdir()) == []
