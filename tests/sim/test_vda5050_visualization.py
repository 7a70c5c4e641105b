"""``visualization`` in the simulation (VDA 5050 §6.13, docs/vda5050.md "In the simulation"): every telemetry
period, to a transport that samples the fleet, each vehicle's position and velocity at that instant.

Derived by hand from vcran/scenarios/vda5050.toml (as tests/sim/test_vda5050_glue.py): the vehicle starts at
home (0, 0) facing +x; order 100 arrives at t = 1 and its first leg, home -> n1 (2, 0), speeds up at 0.5 m/s^2
for 2 s to 1 m/s and slows down again, reaching n1 at t = 5. So at t = 2 it is 0.25 m along at 0.5 m/s, at
t = 3 1 m along at 1 m/s, at t = 4 1.75 m along at 0.5 m/s; ``vx`` is along its heading, ``vy`` 0 (§6.10.6).
"""

from __future__ import annotations

import pytest

import vcran
from transports.scripted import ScriptedTransport
from vcran.core.wire import Outbound, Publish
from vcran.io.sinks import MemorySinks
from vcran.runner import execute


class Sampling(ScriptedTransport):
    """The scenario's script, keeping every visualization the vehicles publish."""

    def __init__(self, scenario: vcran.Scenario) -> None:
        super().__init__(scenario.messages(), frames=True)
        self.shown: list[Publish] = []

    def send(self, out: Outbound) -> None:
        if isinstance(out, Publish) and out.attribute == "visualization":
            self.shown.append(out)
        super().send(out)


def test_each_tick_shows_where_the_vehicle_is_and_how_fast_it_goes():
    scenario = vcran.load_scenario("vda5050")
    transport = Sampling(scenario)
    execute(scenario, transport, MemorySinks())
    first = [(out.t, out.robot, out.message) for out in transport.shown if out.t <= 4.0]
    assert [t for t, _, _ in first] == [0.0, 1.0, 2.0, 3.0, 4.0]  # one per telemetry period (1 s)
    assert {robot for _, robot, _ in first} == {"robot_1"}
    expected = [(0.0, 0.0), (0.0, 0.0), (0.25, 0.5), (1.0, 1.0), (1.75, 0.5)]  # (x, vx): module docstring
    for n, ((t, _, message), (x, vx)) in enumerate(zip(first, expected)):
        position, velocity = message.agv_position, message.velocity
        assert (position.x, position.y, position.theta) == pytest.approx((x, 0.0, 0.0), abs=1e-9)
        assert (velocity.vx, velocity.vy, velocity.omega) == pytest.approx((vx, 0.0, 0.0), abs=1e-9)
        assert position.map_id == "map" and position.position_initialized
        # §6.4: headerId counts this topic's messages from 0; the stamp is simulated time on the 1970 calendar
        assert message.header.header_id == n
        assert message.header.timestamp == f"1970-01-01T00:00:0{int(t)}.00Z"
        assert (message.header.manufacturer, message.header.serial_number) == ("vcran", "0001")
