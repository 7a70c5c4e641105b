"""The bundled VDA 5050 scenarios (issue 31 item 3) in the Yard, until the simulation hosts VDA 5050 vehicles:
the ``vda5050`` script moves the demo's part in three orders (its timing is derived in docs/vda5050.md, "VDA
5050 scenarios", which runs it), and the reference master does every job of ``vda5050-warehouse``.

The Yard produces no parts: each station's production (``produce_every``, up to ``capacity``) is injected
at the times the scenario gives.
"""

from __future__ import annotations

import vcran
from vcran.core.scenario import Scenario
from vcran.core.vda5050.master import Master
from vcran.managers.vda5050 import MasterControl
from vcran.testing.vda5050.yard import Yard


def produce(yard: Yard, scenario: Scenario, until: float) -> None:
    """Each station's parts as the simulation would produce them (SPEC §4), injected into the Yard."""
    for s in scenario.stations:
        limit = s.produce_limit or float("inf")
        t, n = (s.produce_start if s.produce_start is not None else s.produce_every), 0
        while s.produce_every > 0 and t <= until and n < limit:
            yard.call_at(t, lambda s=s: yard.stock.update({s.id: min(s.capacity, yard.stock[s.id] + 1)}))
            t, n = t + s.produce_every, n + 1


class Script(Master):
    """A scenario's script played as it is: each message to its vehicle at its time."""

    def __init__(self, scenario: Scenario) -> None:
        self.scenario = scenario

    def on_start(self) -> None:
        serials = {r.id: r.serial_number for r in self.scenario.robots}
        for entry in self.scenario.script:
            self.handle.call_at(entry.t, self.handle.send, serials[entry.robot], entry.message)


def test_the_vda5050_script_moves_the_part_in_three_orders_and_comes_home() -> None:
    scenario = vcran.load_scenario("vda5050")
    yard = Yard(scenario, Script(scenario))
    produce(yard, scenario, 100.0)
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
    produce(yard, scenario, scenario.settings.duration)
    yard.run(scenario.settings.duration)
    outcomes = [job.outcome for job in yard.jobs.records()]
    assert len(outcomes) == len(list(scenario.workload())) > 0
    assert set(outcomes) == {"completed"}
