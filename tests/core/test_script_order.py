"""Scenario.messages (SPEC §5): the script and its cycles in time order, equal times in file order."""

from __future__ import annotations

from itertools import chain

from hypothesis import given
from hypothesis import strategies as st

from vcran.core.scenario import Cycle, RobotConfig, Scenario, ScriptEntry, Settings, TaskSpec

ROBOT = "robot_1"
SPEC = TaskSpec(path=((1.0, 0.0, None), (2.0, 0.0, 0.5)), actions=("load",))


def scenario(script: tuple[ScriptEntry, ...], cycles: tuple[Cycle, ...]) -> Scenario:
    return Scenario(Settings(duration=100.0), (RobotConfig(ROBOT),), (), script, cycles=cycles)


def test_a_cycle_by_hand():
    cycle = Cycle(t=0.0, robot=ROBOT, every=10.0, until=25.0, prefix="c", tasks=(SPEC,))
    got = [(e.t, e.attribute, e.message.task_id.description) for e in scenario((), (cycle,)).messages()]
    # two motions and one action per repetition, repetitions at 0, 10 and 20 (25 is not before until)
    assert got == [(t, attr, f"c_{k}_1") for k, t in enumerate((0.0, 10.0, 20.0))
                   for attr in ("motion_assignment", "motion_assignment", "action_assignment")]


times = st.integers(0, 6).map(float)


@given(script_times=st.lists(times, max_size=8),
       cycles=st.lists(st.tuples(times, st.integers(1, 4).map(float), st.integers(0, 12).map(float)), max_size=3))
def test_time_order_and_file_order_at_equal_times(script_times, cycles):
    script = tuple(ScriptEntry(t, ROBOT, "cancel_task", raw=n) for n, t in enumerate(sorted(script_times)))
    cs = tuple(Cycle(t, ROBOT, every, until, f"p{n}", (SPEC,)) for n, (t, every, until) in enumerate(cycles))
    # what "time order, equal times in file order" means: a stable sort of the script, then each cycle's
    # entries, by time alone
    every_entry = [*script, *chain.from_iterable(chain.from_iterable(c.repetitions()) for c in cs)]
    expected = sorted(every_entry, key=lambda e: e.t)
    assert list(scenario(script, cs).messages()) == expected
