"""The order in which a fleet manager hears ``ran_error`` and ``ran_status`` (issue 29 item 13; docs/loop.md,
"Order within an instant").

The RAN publishes a ``ran_error`` the moment it happens (at the priority of its cause: an inbound
message, a completion, a fault, a deadline), but ``ran_status`` only at telemetry ticks (every
``telemetry_period``, when it changed), and the link carries what the RAN published at one instant as one
batch, in publication order, ``latency`` later. So, derived by hand for one robot standing on station
``a`` (empty), sent at t = 0 a task of a zero-length motion and a ``load``, with latency 0.5 s: the task
reaches the RAN at 0.5, the motion ends there, the load starts, and fails (no part) after its duration:

* load of 2.5 s: fails at 3.0, a tick: the ``ran_error`` and the ``ran_status`` that lists the task
  cancelled (``action_failed``) are one batch, and the manager hears both at 3.5, the error first;
* load of 2.0 s: fails at 2.5, between ticks: the error reaches the manager at 3.0, the status with the
  next tick's batch (3.0 + 0.5 = 3.5), half a second later.
"""

from __future__ import annotations

import tomllib

import pytest

import vcran
from vcran.core.opil.messages import Message
from vcran.io.scenario_file import parse

SCENARIO = """
[simulation]
duration = 30.0
[simulation.action_durations]
load = {load}
[link]
latency = 0.5
[[robots]]
id = "robot_1"
[[stations]]
id = "a"
position = [0.0, 0.0]
[[stations]]
id = "b"
position = [5.0, 0.0]
[[jobs]]
t = 0.0
id = "j"
pickup = "a"
dropoff = "b"
"""


class Listener(vcran.FleetManager):
    """Sends the load task and notes every ``ran_error`` and ``ran_status`` it hears, in order."""

    def on_start(self) -> None:
        self.heard: list[tuple[float, str, str]] = []

    def on_job(self, job: vcran.Job) -> None:
        self.handle.send_task("robot_1", [(0.0, 0.0)], ["load"], job=job)

    def on_update(self, robot: str, attribute: str, message: Message, t: float) -> None:
        if attribute == "ran_error":
            self.heard.append((t, attribute, message.code))
        elif attribute == "ran_status" and message.cancelled:
            self.heard.append((t, attribute, message.cancelled[0].reason))


@pytest.mark.parametrize("load, expected", [
    (2.5, [(3.5, "ran_error", "load_no_part"), (3.5, "ran_status", "action_failed")]),
    (2.0, [(3.0, "ran_error", "load_no_part"), (3.5, "ran_status", "action_failed")]),
])
def test_a_failure_is_heard_as_ran_error_then_ran_status(load: float, expected: list) -> None:
    manager = Listener()
    vcran.simulate(parse(tomllib.loads(SCENARIO.format(load=load)), "<order>"), manager=manager)
    assert manager.heard == expected
