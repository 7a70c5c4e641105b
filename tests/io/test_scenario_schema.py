"""``vcran schema scenario`` (issue 16): a JSON Schema recorded from the loader's own reads, which editors
use to validate scenario files. It must accept what the loader accepts and catch the common mistakes."""

from __future__ import annotations

import copy
import inspect
import json
import tomllib
from typing import Any

import jsonschema
import pytest
from hypothesis import given, settings

from tests.conftest import ROOT
from vcran import cli
from vcran.io.gen import generate
from vcran.io.scenario_file import parse
from vcran.io.scenario_schema import RecordingTable, scenario_schema
from vcran.io.toml_table import Table
from vcran.testing.scripts import fleets

SCENARIOS = sorted((ROOT / "scenarios").glob("*.toml"))


@pytest.fixture(scope="module")
def validator() -> jsonschema.Draft7Validator:
    schema = scenario_schema()
    jsonschema.Draft7Validator.check_schema(schema)
    return jsonschema.Draft7Validator(schema)


def errors(validator: jsonschema.Draft7Validator, data: dict[str, Any]) -> list[str]:
    return [f"{'.'.join(map(str, e.absolute_path))}: {e.message}" for e in validator.iter_errors(data)]


def demo() -> dict[str, Any]:
    with (ROOT / "scenarios" / "demo.toml").open("rb") as f:
        return tomllib.load(f)


@pytest.mark.parametrize("path", SCENARIOS, ids=[p.name for p in SCENARIOS])
def test_every_bundled_scenario_validates(validator: jsonschema.Draft7Validator, path: Any) -> None:
    with path.open("rb") as f:
        assert errors(validator, tomllib.load(f)) == []


def test_a_generated_fleet_validates(validator: jsonschema.Draft7Validator) -> None:
    assert errors(validator, tomllib.loads(generate(3, 0.1, 7))) == []


@pytest.mark.slow
@settings(max_examples=30)
@given(fleets())
def test_what_the_loader_accepts_validates(data: dict[str, Any]) -> None:
    """The schema is never stricter than the loader (module docstring of vcran.io.scenario_schema)."""
    parse(copy.deepcopy(data))
    jsonschema.validate(json.loads(json.dumps(data)), scenario_schema())


@pytest.mark.parametrize(("mistake", "where"), [
    (lambda d: d["robots"][0].update(max_velocty=1.0), "robots.0"),          # a typo'd key
    (lambda d: d["simulation"].update(duraton=5.0), "simulation"),           # a typo'd key, top table
    (lambda d: d["script"][0].update(kind="motoin"), "script.0.kind"),       # a kind that does not exist
    (lambda d: d["script"][0].pop("robot"), "script.0"),                     # a required field missing
    (lambda d: d["robots"][0].update(max_velocity="fast"), "robots.0.max_velocity"),  # wrong type
    (lambda d: d["simulation"].update(task_timeout=0), "simulation.task_timeout"),    # out of bounds
    (lambda d: d["stations"][0].update(position=[1.0]), "stations.0.position"),     # wrong shape
    (lambda d: d["robots"][0].update(actions=["dance"]), "robots.0.actions.0"),      # unknown action
    (lambda d: d.update(robot=[{"id": "r"}]), ""),                                    # [[robot]] for [[robots]]
], ids=["robot-key", "simulation-key", "kind", "missing-robot", "type", "bound", "shape", "action", "top-key"])
def test_mistakes_are_rejected_where_they_are(validator: jsonschema.Draft7Validator, mistake: Any, where: str) -> None:
    data = demo()
    assert errors(validator, data) == []
    mistake(data)
    found = errors(validator, data)
    assert found, "the schema accepted the mistake"
    assert any(e.startswith(f"{where}:") for e in found), found


def warehouse() -> dict[str, Any]:
    with (ROOT / "scenarios" / "warehouse.toml").open("rb") as f:
        return tomllib.load(f)


@pytest.mark.parametrize(("mistake", "where"), [
    (lambda d: d["link"].update(latncy=0.1), "link"),                                  # a typo'd key
    (lambda d: d["link"].update(inbound="carrier pigeon"), "link.inbound"),            # not a choice
    (lambda d: d["job_stream"].update(dropoff={"dock_1": -1.0}), "job_stream.dropoff"),  # a weight <= 0
    (lambda d: d["job_stream"].update(pickup="line_1"), "job_stream.pickup"),           # a name, not a list
    (lambda d: d["stations"][0].update(dock=[1.0]), "stations.0.dock"),                # wrong shape
    (lambda d: d["manager"].pop("class"), "manager"),                                  # a required field
    (lambda d: d.update(jobs=[{"t": 1.0, "id": "j", "pickup": "line_1"}]), "jobs.0"),  # no dropoff
], ids=["link-key", "inbound", "weight", "pickup-shape", "dock-shape", "manager-class", "job-dropoff"])
def test_closed_loop_mistakes_are_rejected_where_they_are(validator: jsonschema.Draft7Validator, mistake: Any,
                                                          where: str) -> None:
    data = warehouse()
    assert errors(validator, data) == []
    mistake(data)
    found = errors(validator, data)
    assert any(e.startswith(f"{where}:") for e in found), found


def bundled_data(name: str) -> dict[str, Any]:
    with (ROOT / "scenarios" / f"{name}.toml").open("rb") as f:
        return tomllib.load(f)


def first_fault(d: dict[str, Any], kind: str) -> dict[str, Any]:
    return next(f for f in d["faults"] if f["kind"] == kind)


@pytest.mark.parametrize(("name", "mistake", "where"), [
    ("faults", lambda d: first_fault(d, "breakdown").update(kind="meteor"), "faults.0.kind"),   # not a fault
    ("faults", lambda d: first_fault(d, "breakdown").pop("duration"), "faults.0"),  # a breakdown lasts
    ("faults", lambda d: first_fault(d, "motion_failure").update(duration=5.0), "faults.1"),  # one does not
    ("battery", lambda d: d["robots"][0]["battery"].update(capcity=1.0), "robots.0.battery"),   # a typo'd key
], ids=["fault-kind", "breakdown-duration", "failure-duration", "battery-key"])
def test_robot_section_mistakes_are_rejected_where_they_are(validator: jsonschema.Draft7Validator, name: str,
                                                            mistake: Any, where: str) -> None:
    """docs/contract.md §4's sections: a fault's fields depend on its kind (one if/then per kind, as for script kinds)."""
    data = bundled_data(name)
    assert errors(validator, data) == []
    mistake(data)
    assert any(e.startswith(f"{where}:") for e in errors(validator, data)), errors(validator, data)


def test_the_manager_options_are_the_managers_own(validator: jsonschema.Draft7Validator) -> None:
    """[manager.options] are keyword arguments of the manager's class: the schema leaves them open."""
    data = warehouse()
    data["manager"]["options"] = {"max_tries": 3, "anything_the_class_takes": [1, 2]}
    assert errors(validator, data) == []


def test_the_command_prints_the_schema(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["schema", "scenario"]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    assert json.loads(out) == scenario_schema()


def test_the_recording_table_overrides_every_reading_method() -> None:
    """A reading method added to Table but not to RecordingTable would read nothing into the schema."""
    reading = {name for name, member in inspect.getmembers(Table, inspect.isfunction)
               if not name.startswith("_") and name not in ("done", "fail", "bind")}  # bind reads nothing
    missing = {name for name in reading if getattr(RecordingTable, name) is getattr(Table, name)}
    assert reading and missing == set()
