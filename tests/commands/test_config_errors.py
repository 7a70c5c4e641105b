"""Configuration errors fail at start: one line, exit 2, no traceback, nothing written (issue 12 item 11).

A URL that cannot work is refused before anything runs; a well-formed URL where nothing answers is an
Orion that is down, which live mode rides out (docs/contract.md §7).
"""

from __future__ import annotations

import socket

import pytest

from tests.conftest import ROOT
from vcran.cli import main

DEMO = str(ROOT / "scenarios" / "demo.toml")


def one_line_error(capsys, command: str) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("\n") == 1 and err.startswith(f"vcran {command}: "), err
    return err


@pytest.mark.parametrize("url, says", [
    ("not-a-url", "not a valid URL"),
    ("ftp://127.0.0.1:1026", "not a valid URL; expected http://HOST[:PORT][/PATH] or https://"),
    ("http://127.0.0.1:99999", "Port out of range"),
    ("http://127.0.0.1:10x26", "not a valid URL"),
    ("http://", "not a valid URL"),
    ("http://127.0.0.1:1026/?x=1", "a query, fragment or white space"),
    # Orion answered each request to /v2/v2/... 400 "Service not found", and live ran to its end as if Orion were down
    ("http://127.0.0.1:1026/v2", "without /v2 (vcran adds /v2/entities and the rest itself): http://127.0.0.1:1026"),
    ("http://127.0.0.1:1026/orion/v2/", "give Orion's base URL, without /v2"),
    ("http://127.0.0.1:1026/v2/entities", "the rest itself): http://127.0.0.1:1026\n"),
    ("http://127.0.0.1:1026/proxy/v2/entities/", "the rest itself): http://127.0.0.1:1026/proxy\n"),
])
@pytest.mark.parametrize("command", [["live", DEMO], ["send", DEMO], ["orion", "init", DEMO]])
def test_an_orion_url_that_cannot_work_is_refused_at_start(tmp_path, capsys, command, url, says):
    out = tmp_path / "out"
    extra = ["--out", str(out), "--factor", "1000", "--quiet"] if command[0] == "live" else []  # a regression ends fast
    assert main([*command, "--orion", url, *extra]) == 2
    err = one_line_error(capsys, command[0])
    assert says in err and "--orion" in err
    assert not out.exists()  # nothing half-written


@pytest.mark.parametrize("url, says", [
    ("notify", "not a valid URL; expected http://HOST[:PORT][/PATH]"),
    ("https://127.0.0.1:8765/notify", "expected http://"),  # the listener speaks plain HTTP
    ("http://127.0.0.1:70000/notify", "Port out of range"),
    ("http://127.0.0.1:0/notify", "port 0 is no address Orion can send to"),
])
@pytest.mark.parametrize("command", [["live", DEMO], ["manage", "warehouse"]])
def test_a_malformed_notify_url_is_refused_at_start(tmp_path, capsys, command, url, says):
    out = tmp_path / "out"
    assert main([*command, "--orion", "http://127.0.0.1:1026", "--out", str(out), "--notify-url", url,
                 "--factor", "1000"]) == 2
    assert says in one_line_error(capsys, command[0])
    assert not out.exists()


@pytest.mark.parametrize("port", ["70000", "-1"])
def test_broker_port_out_of_range(capsys, port):
    assert main(["broker", "--port", port]) == 2
    assert "out of range" in one_line_error(capsys, "broker")


def test_broker_port_in_use(capsys):
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        assert main(["broker", "--port", str(port)]) == 2
    assert f"cannot listen on 127.0.0.1:{port}: Address already in use" in one_line_error(capsys, "broker")


def test_a_well_formed_but_unreachable_orion_is_ridden_out(tmp_path, capsys):
    with socket.socket() as s:  # a port where nothing listens
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    scenario = tmp_path / "short.toml"
    fleet = (ROOT / "scenarios" / "demo.toml").read_text().split("[[script]]")[0]  # live mode plays no script
    scenario.write_text(fleet.replace("duration = 600.0", "duration = 3.0"))
    code = main(["live", str(scenario), "--orion", f"http://127.0.0.1:{port}", "--out", str(tmp_path / "o"),
                 "--factor", "10", "--quiet"])
    assert code == 0
    assert (tmp_path / "o" / "summary.json").exists()
