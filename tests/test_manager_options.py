"""Which options a fleet manager gets (issue 29 item 9; docs/loop.md, "Which options a fleet manager
gets"): a scenario's ``[manager] options`` are keyword arguments of the class it names, so that class gets
them however it is named, and any other class gets none unless they are given; the same rule for
``vcran run``, ``vcran sweep``, ``vcran fuzz``, ``vcran manage`` and :func:`vcran.simulate`.

Before, ``--manager`` dropped them even for the scenario's own class (``Tuned`` below, which needs its
``tries``: "cannot build"), and a sweep gave them to every class (``Plain``, which takes none: "cannot
build"). Both classes are the reference Dispatcher underneath, so every run here runs its jobs."""

from __future__ import annotations

import csv
import tomllib
from pathlib import Path

import pytest

from tests.commands.test_cli_errors import vcran
from tests.manager_kinds import Plain, Tuned
from vcran import load_scenario, simulate
from vcran.api import build_manager, manager_options
from vcran.core.scenario import ManagerSpec

HERE = "tests.manager_kinds"  # imported by that name here and by vcran: one class object each


#: One robot, three stations, two jobs, and the manager ``Tuned`` with its option.
SCENARIO = f"""
[simulation]
duration = 300.0
until_idle = true
[manager]
class = "{HERE}:Tuned"
options = {{ tries = 2 }}
[[robots]]
id = "robot_1"
[[stations]]
id = "a"
position = [2.0, 0.0]
parts = 5
[[stations]]
id = "b"
position = [6.0, 0.0]
[[jobs]]
t = 1.0
id = "j1"
pickup = "a"
dropoff = "b"
[[jobs]]
t = 2.0
id = "j2"
pickup = "a"
dropoff = "b"
"""


@pytest.fixture
def scenario(tmp_path: Path) -> Path:
    path = tmp_path / "tuned.toml"
    path.write_text(SCENARIO, encoding="utf-8")
    return path


def test_the_rule_by_hand() -> None:
    """Its own class by the same path, or another path to it: the options; any other class, a subclass of
    the scenario's or an unrelated one: none; a scenario without options, or whose class is gone: none."""
    own = ManagerSpec(f"{HERE}:Tuned", (("tries", 2),))
    assert manager_options(own, f"{HERE}:Tuned") == {"tries": 2}
    assert manager_options(own, f"{HERE}:Alias") == {"tries": 2}
    assert manager_options(own, Tuned) == {"tries": 2}
    assert manager_options(own, f"{HERE}:Plain") == {}
    assert manager_options(own, "vcran.managers:Dispatcher") == {}
    assert manager_options(ManagerSpec(f"{HERE}:Tuned"), Tuned) == {}
    assert manager_options(ManagerSpec("no_such_module:Tuned", (("tries", 2),)), Tuned) == {}
    assert manager_options(None, Tuned) == {}


@pytest.mark.parametrize("named", [None, f"{HERE}:Tuned", f"{HERE}:Alias", Tuned])
def test_simulate_gives_the_scenarios_own_class_its_options(scenario: Path, named: object) -> None:
    result = simulate(scenario, manager=named)  # type: ignore[arg-type]
    assert result.summary["jobs"]["completed"] == 2


@pytest.mark.parametrize("named", [f"{HERE}:Plain", Plain])
def test_simulate_gives_another_class_none(scenario: Path, named: object) -> None:
    result = simulate(scenario, manager=named)  # type: ignore[arg-type]
    assert result.summary["jobs"]["completed"] == 2
    manager, _ = build_manager(named, load_scenario(scenario))  # type: ignore[arg-type]
    assert isinstance(manager, Plain) and manager.max_tries == 3  # the Dispatcher's default, not 2


def test_an_instance_is_given_as_built(scenario: Path) -> None:
    mine = Tuned(tries=5)
    assert build_manager(mine, load_scenario(scenario))[0] is mine and mine.max_tries == 5


@pytest.mark.parametrize("named", ["Tuned", "Alias", "Plain"])
def test_vcran_run_manager(capsys: pytest.CaptureFixture[str], scenario: Path, tmp_path: Path, named: str) -> None:
    code, _, err = vcran(capsys, "run", str(scenario), "--out", str(tmp_path / named), "--manager",
                         f"{HERE}:{named}", "--quiet")
    assert (code, err) == (0, "")


def test_vcran_run_manager_that_needs_options_the_scenario_gives_another_class(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """The scenario names the Dispatcher with ``max_tries``: ``--manager Tuned``, another class, gets none
    of them, so it cannot be built, and says so (exit 2)."""
    path = tmp_path / "d.toml"
    path.write_text(SCENARIO.replace(f'"{HERE}:Tuned"', '"vcran.managers:Dispatcher"')
                    .replace("tries = 2", "max_tries = 2"), encoding="utf-8")
    code, _, err = vcran(capsys, "run", str(path), "--out", str(tmp_path / "o"), "--manager", f"{HERE}:Tuned")
    assert code == 2 and "cannot build fleet manager tests.manager_kinds:Tuned with options {}" in err


@pytest.mark.slow
def test_vcran_sweep_gives_the_scenarios_class_its_options_and_another_none(
        capsys: pytest.CaptureFixture[str], scenario: Path, tmp_path: Path) -> None:
    """Three variants: Tuned by another path (its options), Plain (none), Plain with options the sweep
    gives it (the Dispatcher's own, here: Plain takes none, so that run fails, as given). The kept runs'
    scenario.toml files say which options each ran with."""
    sweep = tmp_path / "s.toml"
    sweep.write_text(f'scenario = "{scenario.as_posix()}"\nseeds = [1]\n'
                     f'[[variants]]\nmanager = "{HERE}:Alias"\n'
                     f'[[variants]]\nmanager = "{HERE}:Plain"\n'
                     f'[[variants]]\nmanager = "{HERE}:Plain"\n"manager.options.max_tries" = 4\n', encoding="utf-8")
    out = tmp_path / "out"
    code, _, _ = vcran(capsys, "sweep", str(sweep), "--out", str(out), "--workers", "1", "--keep-runs", "--quiet")
    assert code == 1  # the third run fails: Plain was given an option it does not take
    rows = list(csv.DictReader((out / "runs.csv").open()))
    assert [r["error"] for r in rows[:2]] == ["", ""] and [r["jobs_completed"] for r in rows[:2]] == ["2", "2"]
    assert "Plain with options {'max_tries': 4}" in rows[2]["error"]
    kept = [tomllib.loads((out / "runs" / f"000{i}" / "scenario.toml").read_text())["manager"] for i in range(3)]
    assert kept == [{"class": f"{HERE}:Alias", "options": {"tries": 2}}, {"class": f"{HERE}:Plain"},
                    {"class": f"{HERE}:Plain", "options": {"max_tries": 4}}]


@pytest.mark.parametrize("named", ["Alias", "Plain"])
def test_vcran_fuzz_manager(capsys: pytest.CaptureFixture[str], scenario: Path, tmp_path: Path, named: str) -> None:
    pytest.importorskip("hypothesis")
    code, out, err = vcran(capsys, "fuzz", str(scenario), "--manager", f"{HERE}:{named}", "--examples", "2",
                           "--jobs", "2", "--save", str(tmp_path / "f.toml"))
    assert "cannot build" not in err and code in (0, 1), err
    assert f"{HERE}:{named} " in out + err  # the search ran: a clean one or a finding names the manager


@pytest.mark.parametrize("named, message", [
    ("Alias", "cannot read the fleet from"),  # built with its options; then Orion is not there
    ("Plain", "cannot read the fleet from"),
])
def test_vcran_manage_manager(capsys: pytest.CaptureFixture[str], scenario: Path, named: str, message: str) -> None:
    code, _, err = vcran(capsys, "manage", str(scenario), "--orion", "http://127.0.0.1:1", "--manager",
                         f"{HERE}:{named}")
    assert code == 2 and message in err, err
