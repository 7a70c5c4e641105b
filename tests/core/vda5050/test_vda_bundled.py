"""The bundled VDA 5050 scenarios (issue 31 item 3) in the Yard, until the simulation hosts VDA 5050 vehicles:
the ``vda5050`` script moves the demo's part in three orders (its timing is derived in docs/vda5050.md, "VDA
5050 scenarios", which runs it), and the reference master does every job of ``vda5050-warehouse``.

The Yard produces no parts: :func:`vcran.testing.vda5050.scripted.produce` injects each station's production.
"""

from __future__ import annotations

import tomllib

import pytest

import vcran
from tests.io.test_scenario_vda5050 import FLEET
from vcran.io.scenario_file import parse
from vcran.managers.vda5050 import MasterControl
from vcran.testing.vda5050.scripted import ScriptedMaster, produce
from vcran.testing.vda5050.yard import Yard


def test_the_vda5050_script_moves_the_part_in_three_orders_and_comes_home() -> None:
    scenario = vcran.load_scenario("vda5050")
    yard = Yard(scenario, ScriptedMaster(scenario))
    produce(yard, 100.0)
    yard.run(100.0)
    # each order accepted when it arrives and completed before the next is sent (none refused)
    seen = [(e["event"], e["order_id"]) for e in yard.events if e["event"].startswith("Order")]
    assert seen == [("OrderAccepted", "100"), ("OrderEnded", "100"), ("OrderAccepted", "200"),
                    ("OrderEnded", "200"), ("OrderAccepted", "300"), ("OrderEnded", "300")]
    assert all(e["how"] == "completed" for e in yard.events if e["event"] == "OrderEnded")
    assert yard.stock == {"conveyor_1": 0, "conveyor_2": 1}  # demo.md: the part on conveyor 2
    last = yard.states("0001")[-1]
    assert (last.agv_position.x, last.agv_position.y, last.agv_position.theta) == (0.0, 0.0, 0.0)  # home
    assert not last.errors and not last.loads


def test_the_reference_master_does_every_job_of_the_vda5050_warehouse() -> None:
    scenario = vcran.load_scenario("vda5050-warehouse")
    assert scenario.manager is not None
    yard = Yard(scenario, MasterControl(**dict(scenario.manager.options)), latency=scenario.link.latency)
    produce(yard, scenario.settings.duration)
    yard.run(scenario.settings.duration)
    outcomes = [job.outcome for job in yard.jobs.records()]
    assert len(outcomes) == len(list(scenario.workload())) > 0
    assert set(outcomes) == {"completed"}


def test_production_in_the_yard_is_the_simulations() -> None:
    """docs/contract.md §4 (docs/scenarios.md): a part every produce_every from produce_start (default: produce_every), a
    full station skipping its turn, at most produce_limit parts. Up to t = 24: ticks at 10 and 20 (a, b, c),
    at 5 and 15 (d)."""
    stations = {"a": "capacity = 1", "b": "produce_limit = 1", "c": "parts = 3", "d": "produce_start = 5.0"}
    text = FLEET + "".join(f'[[stations]]\nid = "{name}"\nposition = [{10.0 * k}, 0.0]\nproduce_every = 10.0\n{extra}\n'
                           for k, (name, extra) in enumerate(stations.items(), start=1))
    yard = Yard(parse(tomllib.loads(text)), ScriptedMaster(parse(tomllib.loads(text))))
    produce(yard, 24.0)
    yard.run(100.0)
    assert yard.stock == {"a": 1, "b": 1, "c": 5, "d": 2}


def test_the_scripted_master_refuses_a_payload_it_cannot_send() -> None:
    scenario = parse(tomllib.loads(FLEET + '[[script]]\nt = 1.0\nrobot = "r1"\nkind = "order"\npayload = "{}"\n'))
    with pytest.raises(ValueError, match="script entry at t = 1: a payload, which the Yard cannot send"):
        Yard(scenario, ScriptedMaster(scenario))
