"""``ran_status`` carries the parts the robot carries (docs/contract.md §2; issue 29 item 4): a fleet manager must be
able to see a load that a failed action left where it was. It is published when it changes, a change of
the load alone included."""

from __future__ import annotations

import tomllib

import vcran
from vcran.core.opil.messages import RanStatus
from vcran.io.scenario_file import parse
from vcran.io.sinks import MemorySinks
from vcran.runner import execute
from vcran.sim.opil.loop import ClosedLoop
from vcran.sim.timing import FAULT, at

# One robot, a station with parts within reach of (2, 0) and an empty one within reach of (6, 0).
FLEET = """
[simulation]
duration = {duration}
until_idle = true
seed = 1
[simulation.action_durations]
load = 2.0
unload = 2.0
[[robots]]
id = "robot_1"
pose = [0.0, 0.0, 0.0]
max_velocity = 1.0
capacity = 2
carrying = {carrying}
[[stations]]
id = "a"
position = [2.0, 1.0]
reach = 1.5
parts = 3
[[stations]]
id = "b"
position = [6.0, 1.0]
reach = 1.5
"""


def scenario(carrying: int = 0, until: str = "until_idle = true", duration: float = 120.0) -> vcran.Scenario:
    text = FLEET.format(carrying=carrying, duration=duration).replace("until_idle = true", until)
    return parse(tomllib.loads(text), "<test>")


class LoadThenUnload(vcran.FleetManager):
    """Task L loads at a; once ran_status shows L completed, task U unloads at b. Keeps every ran_status."""

    attributes = frozenset({"ran_status"})

    def __init__(self) -> None:
        self.statuses: list[RanStatus] = []
        self.unloading = False

    def on_start(self) -> None:
        self.handle.send_task("robot_1", [(2.0, 0.0)], ["load"], task="L")

    def on_update(self, robot, attribute, message, t) -> None:
        self.statuses.append(message)
        if vcran.id_for("L") in message.completed and not self.unloading:
            self.unloading = True
            self.handle.send_task("robot_1", [(6.0, 0.0)], ["unload"], task="U")


def test_a_manager_sees_the_load_in_ran_status_change_with_each_load_and_unload():
    manager = LoadThenUnload()
    result = vcran.simulate(scenario(), manager=manager)
    assert result.summary["robots"]["robot_1"]["completed"] == ["L", "U"]
    # by hand: nothing on board at the start; one part once L's load succeeded (the status that shows L
    # completed); none once U's unload succeeded
    first_l = next(s for s in manager.statuses if vcran.id_for("L") in s.completed)
    first_u = next(s for s in manager.statuses if vcran.id_for("U") in s.completed)
    assert manager.statuses[0].carrying == 0 and first_l.carrying == 1 and first_u.carrying == 0
    loads = [s.carrying for s in manager.statuses]
    assert [c for i, c in enumerate(loads) if i == 0 or c != loads[i - 1]] == [0, 1, 0]


def test_the_first_status_shows_what_the_robot_carries_at_the_start():
    manager = LoadThenUnload()
    vcran.simulate(scenario(carrying=2), manager=manager)
    assert manager.statuses[0].carrying == 2


class Statuses(vcran.FleetManager):
    attributes = frozenset({"ran_status"})

    def __init__(self) -> None:
        self.got: list[tuple[float, RanStatus]] = []

    def on_update(self, robot, attribute, message, t) -> None:
        self.got.append((t, message))


def test_a_change_of_the_load_alone_publishes_ran_status():
    """ran_status goes out only when it changes (vcran/sim/opil/ran.py): the load is part of it, so a change
    of the load is a change, even when RanLogic's state and queue stay as they were (here the robot has
    no task at all; the load is set by hand at 2.5 s)."""
    sc = scenario(until="until_idle = false", duration=6.0)
    manager = Statuses()
    loop = ClosedLoop(sc, manager, lambda *a: None)

    def load_by_hand(model) -> None:
        robot = model.robots[0]
        at(model.env, 2.5, FAULT).callbacks.append(lambda _: setattr(robot, "carrying", 1))

    execute(sc, loop, MemorySinks(), on_start=load_by_hand)
    # by hand: the status of t = 0 (nothing on board) arrives at 0.05 (the default latency); the next
    # tick after 2.5 s, t = 3, publishes the load, which arrives at 3.05; nothing else ever changes
    assert [(t, s.carrying, s.state) for t, s in manager.got] == [(0.05, 0, "WAITING"), (3.05, 1, "WAITING")]
