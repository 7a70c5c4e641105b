"""docs/contract.md §12 safety fields and deadlock settings in scenario files (issue 32): ``[traffic]`` for the fleet,
``[robots.field]`` for one robot. Read into the model, their problems told as one line naming the file, the
table and the field (the rules are :mod:`vcran.core.validity.safety`'s, the reader only locates them; a
scenario built in code is told the same), written back by the scenario writer, in the trace header only
when set, and off by default."""

from __future__ import annotations

import dataclasses
import tomllib

import jsonschema
import pytest

from vcran.core.scenario import TrafficSettings
from vcran.core.traffic.fields import FieldSpec
from vcran.core.validity import validate
from vcran.io.scenario_file import ScenarioError, load, parse
from vcran.io.scenario_schema import scenario_schema
from vcran.io.scenario_toml import dumps

FLEET = """
[simulation]
duration = 60.0
[[robots]]
id = "robot_1"
[[robots]]
id = "robot_2"
"""

TRAFFIC = """
[traffic]
field = { margin = 2.0 }
deadlock_bound = 120.0
on_deadlock = "cancel"
"""

OWN = """
[robots.field]
margin = 0.5
reaction = 0.3
braking = false
side = 0.1
"""


def read(text: str):
    return parse(tomllib.loads(text), "<test>")


def test_fields_are_off_by_default() -> None:
    s = read(FLEET)
    assert s.traffic == TrafficSettings(field=None, deadlock_bound=None, on_deadlock="continue")
    assert [s.traffic.field_of(r) for r in s.robots] == [None, None] and not s.traffic.any_field(s.robots)
    # the trace header (fleet_dict) of a scenario without them is what it was before docs/contract.md §12's fields
    header = s.fleet_dict()
    assert "traffic" not in header and all("field" not in r for r in header["robots"])


def test_the_fleet_field_is_every_robots_unless_it_has_its_own() -> None:
    s = read(FLEET + OWN + TRAFFIC)  # [robots.field] after robot_2's [[robots]]: robot_2's own
    assert s.traffic == TrafficSettings(FieldSpec(2.0), 120.0, "cancel")
    assert s.robots[0].field is None and s.robots[1].field == FieldSpec(0.5, 0.3, False, 0.1)
    assert [s.traffic.field_of(r) for r in s.robots] == [FieldSpec(2.0), FieldSpec(0.5, 0.3, False, 0.1)]
    assert s.traffic.any_field(s.robots)


def test_a_robots_own_field_alone_turns_traffic_on() -> None:
    s = read(FLEET + OWN)
    assert s.traffic.any_field(s.robots)
    assert [s.traffic.field_of(r) for r in s.robots] == [None, FieldSpec(0.5, 0.3, False, 0.1)]


def test_the_writer_round_trips_them() -> None:
    s = read(FLEET + OWN + TRAFFIC)
    again = read(dumps(s.fleet_dict()))
    assert (again.traffic, again.robots) == (s.traffic, s.robots)


@pytest.mark.parametrize(("extra", "message"), [
    ("[traffic]\nfield = { margin = -1.0 }", "traffic.field: field 'margin': must be at least 0.0, got -1.0"),
    ("[traffic]\nfield = { reaction = 1.0 }", "traffic.field: field 'margin': missing"),
    ("[traffic]\nfield = { margin = 1.0, lenght = 2.0 }", "traffic.field: field 'lenght': unknown key (a typo?)"),
    ('[traffic]\nfield = { margin = 1.0 }\non_deadlock = "stop"',
     "traffic: field 'on_deadlock': unknown on_deadlock 'stop'; known: continue, cancel"),
    ("[traffic]\nfield = { margin = 1.0 }\ndeadlock_bound = 0",
     "traffic: field 'deadlock_bound': must be positive, got 0"),
    ('[robots.field]\nmargin = 1.0\nbraking = "yes"',
     "robots[1].field: field 'braking': expected true or false, got 'yes'"),
    ("[robots.field]\nmargin = 1.0\nside = -0.5", "robots[1].field: field 'side': must be at least 0.0, got -0.5"),
    # settings for blocking without a field to block: a mistake, not a run that silently never blocks
    ("[traffic]\ndeadlock_bound = 60.0", "traffic: field 'deadlock_bound': no robot has a protective field"),
    ('[traffic]\non_deadlock = "cancel"', "traffic: field 'on_deadlock': no robot has a protective field"),
])
def test_problems_name_the_table_and_the_field(extra: str, message: str) -> None:
    with pytest.raises(ScenarioError) as caught:
        read(FLEET + extra)
    assert str(caught.value).startswith(f"<test>: {message}")


def test_a_scenario_built_in_code_is_told_the_same() -> None:
    """The rules are the model's: a field replaced in code is checked like one read from a file."""
    s = read(FLEET + TRAFFIC)
    bad = dataclasses.replace(s, traffic=dataclasses.replace(s.traffic, deadlock_bound=-3.0))
    assert [str(p) for p in validate(bad)] == ["traffic: field 'deadlock_bound': must be positive, got -3.0"]
    robots = (s.robots[0], dataclasses.replace(s.robots[1], field="wide"))
    assert [str(p) for p in validate(dataclasses.replace(s, robots=robots))] == [
        "robots[1]: field 'field': expected a FieldSpec or None, got str"]
    off = dataclasses.replace(s, traffic=TrafficSettings(deadlock_bound=5.0))
    assert [p.path for p in validate(off)] == ["traffic.deadlock_bound"]


def test_the_schema_knows_them() -> None:
    validator = jsonschema.Draft7Validator(scenario_schema())
    good = tomllib.loads(FLEET + OWN + TRAFFIC)
    assert list(validator.iter_errors(good)) == []
    for bad in ({"field": {"margin": 1.0, "lenght": 2.0}}, {"on_deadlock": "stop"}, {"deadlock_bound": 0}):
        assert list(validator.iter_errors({**good, "traffic": bad})), bad


def test_bundled_scenarios_without_fields_load_as_before() -> None:
    for name in ("demo", "warehouse", "crossing"):
        sc = load(name)
        assert not sc.traffic.any_field(sc.robots)
