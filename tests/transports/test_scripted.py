"""The scripted transport delivers a script's messages at their times (docs/contract.md §5), however it is given."""

from __future__ import annotations

import simpy

from transports.scripted import ScriptedTransport
from vcran.core.scenario import Cycle, RobotConfig, Scenario, ScriptEntry, Settings, TaskSpec

ROBOT = "robot_1"
SPEC = TaskSpec(path=((1.0, 0.0, None),), actions=("load",))


def delivered(script) -> list[tuple[float, str, object]]:
    env = simpy.Environment()
    got: list[tuple[float, str, object]] = []
    transport = ScriptedTransport(script)
    transport.attach(env, lambda i: got.append((env.now, i.attribute, i.raw if i.message is None else
                                                i.message.task_id.description)))
    env.run()
    assert transport.exhausted
    return got


def test_a_scenario_script_and_the_same_entries_as_a_list_are_delivered_alike():  # issue 14 item 5
    script = (ScriptEntry(0.5, ROBOT, "cancel_task", raw=1), ScriptEntry(4.0, ROBOT, "cancel_task", raw=2))
    cycle = Cycle(t=0.0, robot=ROBOT, every=4.0, until=6.0, prefix="c", tasks=(SPEC,))
    scenario = Scenario(Settings(duration=10.0), (RobotConfig(ROBOT),), (), script, cycles=(cycle,))
    by_hand = [(0.0, "motion_assignment", "c_0_1"), (0.0, "action_assignment", "c_0_1"),
               (0.5, "cancel_task", 1),
               (4.0, "cancel_task", 2), (4.0, "motion_assignment", "c_1_1"), (4.0, "action_assignment", "c_1_1")]
    assert delivered(scenario.messages()) == by_hand
    assert delivered(list(scenario.messages())) == by_hand


def test_an_entry_behind_the_clock_is_delivered_at_once():  # as given: the transport never goes back
    script = [ScriptEntry(t, ROBOT, "cancel_task", raw=n) for n, t in enumerate((2.0, 1.0, 3.0, 3.0))]
    assert delivered(script) == [(2.0, "cancel_task", 0), (2.0, "cancel_task", 1), (3.0, "cancel_task", 2),
                                 (3.0, "cancel_task", 3)]
