"""``[simulation] state_interval`` (docs/scenarios.md "VDA 5050 vehicles", docs/contract.md §11): the longest a
VDA 5050 vehicle goes without publishing its state. §6.10 (the specification's text): "The AGV state message
will be published with occurrence of relevant events or at the latest every 30s"; unset, a vehicle keeps those
30 s, and a scenario may ask for more often (a live master's 1 Hz state), never less often, and only of VDA
5050 vehicles: OPIL robots send their telemetry every ``telemetry_period``.

Expected values are derived by hand from that text: a state at the start, then one whenever ``state_interval``
passed since the last one, counted again from every state an event publishes.
"""

from __future__ import annotations

from dataclasses import replace

import pytest

from tests.io.test_scenario_vda5050 import load, refused
from tests.sim.test_vda5050_glue import ONE_VEHICLE
from vcran.cli import main
from vcran.core.validity import validate
from vcran.core.vda5050.fleet import vehicle_config
from vcran.io.scenario_schema import scenario_schema
from vcran.io.trace import read_header, trace_in, trace_records

#: The glue tests' vehicle, idle for 5 s (no until_idle: it would end the run at once), a state each second.
IDLE = ONE_VEHICLE.replace("until_idle = true\n", "").replace("duration = 100.0", "duration = 5.0\nstate_interval = 1.0")

#: startPause at 2.5 s: ``paused`` turns true, an event (§6.10 "relevant events"), so a state goes out then.
PAUSE_AT_2_5 = """
[[script]]
t = 2.5
robot = "agv"
kind = "instantActions"
message = '{"actions": [{"actionType": "startPause", "actionId": "p1", "blockingType": "HARD"}]}'
"""

OPIL = '[simulation]\nduration = 5.0\nstate_interval = 1.0\n[[robots]]\nid = "r1"\n'


def test_state_interval_is_read_and_reaches_each_vehicle() -> None:
    s = load(IDLE)
    assert s.settings.state_interval == 1.0
    assert vehicle_config(s.robots[0], s.settings).state_interval == 1.0
    unset = load(IDLE.replace("state_interval = 1.0\n", ""))
    assert unset.settings.state_interval is None  # unset: the protocol's own 30 s (§6.10)
    assert vehicle_config(unset.robots[0], unset.settings).state_interval == 30.0
    assert "state_interval" not in unset.fleet_dict()["simulation"]  # so every existing trace header stays
    assert s.fleet_dict()["simulation"]["state_interval"] == 1.0  # as written, which a replay reads back
    assert load(IDLE.replace("state_interval = 1.0", "state_interval = 30")).settings.state_interval == 30  # "at the latest"
    assert scenario_schema()["properties"]["simulation"]["properties"]["state_interval"]["type"] == "number"


@pytest.mark.parametrize(("value", "told"), [
    ("0", "must be positive, got 0"),
    ("-1.0", "must be positive, got -1.0"),
    ("30.5", 'must be at most 30 seconds, got 30.5 (VDA 5050 §6.10: a state "at the latest every 30s")'),
    ('"1"', "expected a finite number, got '1'"),
])
def test_a_bad_state_interval_is_refused_naming_the_field(value: str, told: str) -> None:
    assert refused(IDLE.replace("state_interval = 1.0", f"state_interval = {value}")) == (
        f"x.toml: simulation: field 'state_interval': {told}")


def test_an_opil_scenario_refuses_state_interval() -> None:
    assert refused(OPIL) == (
        "x.toml: simulation: field 'state_interval': the longest a VDA 5050 vehicle goes without a state (§6.10); "
        "this scenario's robots speak opil, whose telemetry_period says how often they send theirs (set "
        "[simulation] protocol = \"vda5050\")")
    s = load(IDLE)  # the model's rule, so a scenario changed in code is told the same
    assert [str(p) for p in validate(replace(s, settings=replace(s.settings, protocol="opil")))] == [
        "simulation: field 'state_interval': the longest a VDA 5050 vehicle goes without a state (§6.10); this "
        "scenario's robots speak opil, whose telemetry_period says how often they send theirs (set [simulation] "
        "protocol = \"vda5050\")"]


def test_an_idle_vehicle_publishes_a_state_every_state_interval_and_after_each_event(tmp_path) -> None:
    """state_interval = 1 over 5 s: states at 0 (the vehicle comes up), 1 and 2 (idle, each 1 s after the
    last); startPause at 2.5 publishes one (an event), so the next due are 3.5 and 4.5, none at 3 or 4.
    headerId counts them from 0 (§6.4). The factsheet says the same (§6.15 defaultStateInterval), and the
    replay, reading the setting from the trace header, publishes the same bytes."""
    path = tmp_path / "idle.toml"
    path.write_text(IDLE + PAUSE_AT_2_5)
    out = tmp_path / "run"
    assert main(["run", str(path), "--out", str(out), "--quiet"]) == 0
    records = trace_records(out)
    states = [(r["t"], r["raw"]["headerId"], r["raw"]["paused"]) for r in records if r["attr"] == "state"]
    assert states == [(0.0, 0, False), (1.0, 1, False), (2.0, 2, False), (2.5, 3, True), (3.5, 4, True),
                      (4.5, 5, True)]
    [sheet] = [r["raw"] for r in records if r["attr"] == "factsheet"]
    assert sheet["protocolLimits"]["timing"]["defaultStateInterval"] == 1.0
    assert read_header(trace_in(out))["fleet"]["simulation"]["state_interval"] == 1.0
    assert main(["replay", str(out), "--verify", "--quiet"]) == 0


def test_without_state_interval_an_idle_vehicle_waits_30_s(tmp_path) -> None:
    """The default of §6.10: over 65 idle seconds, states at 0, 30 and 60."""
    path = tmp_path / "idle.toml"
    path.write_text(IDLE.replace("state_interval = 1.0\n", "").replace("duration = 5.0", "duration = 65.0"))
    out = tmp_path / "run"
    assert main(["run", str(path), "--out", str(out), "--quiet"]) == 0
    assert [r["t"] for r in trace_records(out) if r["attr"] == "state"] == [0.0, 30.0, 60.0]
