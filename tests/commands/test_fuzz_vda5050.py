"""``vcran fuzz`` on a VDA 5050 scenario without a manager (issue 31 item 6, docs/contract.md §11, docs/fuzzing.md
"VDA 5050 scenarios"): the script is perturbed as a master perturbs it and every run is checked against VDA
5050's properties; a vehicle with a deliberately broken acceptance rule is found, shrunk and saved.

Hand-derived expectations are in each test's docstring, from the specification (§6.6.2, Figure 8; §6.6.4)
and the scenarios' own numbers, never from the vehicle's code.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import pytest

from tests.sim.test_vda5050_glue import ONE_VEHICLE
from vcran.cli import main
from vcran.core.vda5050 import acceptance
from vcran.io.scenario_file import load
from vcran.testing.scripts import load_text
from vcran.testing.vda5050.fuzz import Drop, Duplicate, Instant, Malformed, Resend
from vcran.testing.vda5050_runs import perturbed_toml, run_variant

#: One vehicle at (0, 0), order o1 (orderUpdateId 2) at t = 1 to (10, 0): a 10 m leg at 1 m/s with 0.5 m/s^2
#: up and down takes 2 + 8 + 2 = 12 s, so the order executes from 1 to 13 and a re-send of it with
#: orderUpdateId 1 between those is stale: rejected with an orderUpdateError (§6.6.4.3).
LONG = ONE_VEHICLE + """
[[script]]
t = 1.0
robot = "agv"
kind = "order"
message.orderId = "o1"
message.orderUpdateId = 2
message.nodes = [
  { nodeId = "a", sequenceId = 0, released = true, nodePosition = { x = 0.0, y = 0.0, mapId = "map" }, actions = [] },
  { nodeId = "b", sequenceId = 2, released = true, nodePosition = { x = 10.0, y = 0.0, mapId = "map" }, actions = [] },
]
message.edges = [
  { edgeId = "a-b", sequenceId = 1, released = true, startNodeId = "a", endNodeId = "b", actions = [] },
]
"""


def variant(base_text: str, ops: list[object], tmp_path: Path) -> tuple[list[str], list[tuple[float, str, object]]]:
    """The violations of one perturbed variant, run with its rerun and replay, and its order events."""
    from vcran.io.trace import event_records

    base = load_text(base_text)
    with tempfile.TemporaryDirectory(dir=tmp_path) as work:
        problems = run_variant(load_text(perturbed_toml(base, ops)), Path(work))
        verdicts = [(e["t"], e["event"], (e.get("error") or {}).get("errorType"))
                    for e in event_records(Path(work) / "a" / "events.jsonl.zst") if e["event"].startswith("order_")]
    return problems, verdicts


@pytest.fixture
def stale_bug(monkeypatch: pytest.MonkeyPatch) -> None:
    """A deliberately broken vehicle: a stale orderUpdateId is discarded as if it were a duplicate, where
    §6.6.4.3 says to reject it (orderUpdateError)."""
    decide = acceptance.decide

    def broken(order, standing, config):  # type: ignore[no-untyped-def]
        if standing.order_id == order.order_id and order.order_update_id < standing.order_update_id:
            return acceptance.DISCARD
        return decide(order, standing, config)

    monkeypatch.setattr(acceptance, "decide", broken)


def test_a_stale_update_is_rejected_and_the_properties_hold(tmp_path: Path) -> None:
    """LONG with o1 re-sent at 3 with orderUpdateId 1 (stale while o1 runs, §6.6.4.3): rejected; the order
    still ends completed at 13; the vehicle's verdicts are the model's, its states valid, its rerun
    byte-identical and its replay verified."""
    problems, verdicts = variant(LONG, [Resend(0, 2.0, -1)], tmp_path)
    assert problems == []
    assert verdicts == [(1.0, "order_accepted", None), (3.0, "order_rejected", "orderUpdateError"),
                        (13.0, "order_ended", None)]


def test_the_broken_vehicle_fails_the_acceptance_property(stale_bug: None, tmp_path: Path) -> None:
    """The same variant with the broken rule: the vehicle discards where the model rejects."""
    problems, verdicts = variant(LONG, [Resend(0, 2.0, -1)], tmp_path)
    assert (3.0, "order_discarded", None) in verdicts
    assert len(problems) == 1 and "the vehicle's verdict is discard, the reference model's orderUpdateError" in problems[0]


def test_the_demo_s_perturbations_keep_the_properties(tmp_path: Path) -> None:
    """The bundled vda5050 under a duplicate of order 100 (same orderUpdateId: discarded, §6.6.4.3 "the
    second order will be ignored"), order 200 dropped (so 300 arrives with the vehicle on dock_1, not on 300's
    first node dock_2: rejected with an orderError, Figure 8 (4)), a stateRequest and a malformed order: the
    properties hold and the vehicle's verdicts are these."""
    ops = [Duplicate(0, 3.0), Drop(1), Instant(2.5, "robot_1", "stateRequest"),
           Malformed(30.0, "robot_1", "order", "{}")]
    problems, verdicts = variant(Path(load("vda5050").source).read_text(), ops, tmp_path)
    assert problems == []
    assert [(v, e) for _, v, e in verdicts] == [
        ("order_accepted", None), ("order_discarded", None), ("order_ended", None),
        ("order_rejected", "validationError"), ("order_rejected", "orderError")]


def test_vcran_fuzz_vda5050_runs_clean(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["fuzz", "vda5050", "--examples", "5", "--fast"]) == 0
    assert "5 examples of vda5050 ran clean (seed 0)" in capsys.readouterr().out


@pytest.mark.slow
def test_vcran_fuzz_finds_the_broken_vehicle_and_saves_the_shrunk_script(
        stale_bug: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The search finds the broken rule on LONG, shrinks it to the one stale re-send, prints and saves a
    scenario file that fails the same way when run; the unbroken vehicle passes the same search."""
    scenario, saved = tmp_path / "long.toml", tmp_path / "fail.toml"
    scenario.write_text(LONG)
    assert main(["fuzz", str(scenario), "--examples", "40", "--seed", "1", "--fast", "--save", str(saved)]) == 1
    text = saved.read_text()
    assert text in capsys.readouterr().out
    assert "perturbations: [Resend(index=0, after=0.5, update=-1)]" in text
    assert "the reference model's orderUpdateError" in text
    with tempfile.TemporaryDirectory(dir=tmp_path) as work:
        assert any("orderUpdateError" in p for p in run_variant(load_text(text), Path(work), again=False))


@pytest.mark.slow
def test_the_unbroken_vehicle_passes_that_search(tmp_path: Path) -> None:
    scenario = tmp_path / "long.toml"
    scenario.write_text(LONG)
    assert main(["fuzz", str(scenario), "--examples", "40", "--seed", "1", "--fast"]) == 0


def test_a_vda5050_scenario_with_an_opil_manager_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """With ``--manager`` the master is fuzzed (docs/fuzzing.md, "A VDA 5050 master"); an OPIL fleet manager is
    not one: one clear line naming both kinds, exit 2."""
    assert main(["fuzz", "vda5050-warehouse", "--manager", "vcran.managers:Dispatcher", "--examples", "1"]) == 2
    err = capsys.readouterr().err
    assert "is an OPIL fleet manager (vcran.FleetManager); this scenario's robots speak VDA 5050" in err
    assert err.startswith("vcran fuzz: ") and err.count("\n") == 1
