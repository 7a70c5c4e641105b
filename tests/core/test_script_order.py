"""Scenario.messages (docs/contract.md §5): the script and its cycles in time order, equal times in file order."""

from __future__ import annotations

import math
from itertools import chain

from hypothesis import given
from hypothesis import strategies as st

from vcran.core.scenario import Cycle, RobotConfig, Scenario, Script, ScriptEntry, Settings, TaskSpec

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
    every_entry = [*script, *chain.from_iterable(scenario((), (c,)).messages() for c in cs)]
    expected = sorted(every_entry, key=lambda e: e.t)
    assert list(scenario(script, cs).messages()) == expected


def test_a_cycle_starting_at_minus_zero_keeps_that_time():  # docs/contract.md §5: entries at exactly the written time
    cycle = Cycle(t=-0.0, robot=ROBOT, every=10.0, until=15.0, prefix="c", tasks=(SPEC,))
    script = scenario((), (cycle,)).messages()
    for times in ([e.t for e in script], [t for t, run in scenario((), (cycle,)).messages().runs() for _ in run]):
        assert [math.copysign(1.0, t) for t in times[:3]] == [-1.0] * 3 and times[3:] == [10.0] * 3


def test_the_script_run_by_run_is_its_entries_in_runs_of_one_time():  # issue 14 item 5: Script.runs
    script = (ScriptEntry(0.0, ROBOT, "cancel_task", raw=1), ScriptEntry(10.0, ROBOT, "cancel_task", raw=2))
    cycle = Cycle(t=0.0, robot=ROBOT, every=10.0, until=15.0, prefix="c", tasks=(SPEC,))
    entries = list(scenario(script, (cycle,)).messages())
    runs = [(t, list(run)) for t, run in scenario(script, (cycle,)).messages().runs()]
    # by hand: at 0 the script's entry then the cycle's three messages (a run each); at 10 likewise
    assert [(t, [i.raw if i.message is None else i.message.task_id.description for i in run]) for t, run in runs] \
        == [(0.0, [1]), (0.0, ["c_0_1"] * 3), (10.0, [2]), (10.0, ["c_1_1"] * 3)]
    assert [(t, i.entity, i.attribute, i.message, i.raw) for t, run in runs for i in run] \
        == [(e.t, e.robot, e.attribute, e.message, e.raw) for e in entries]


def test_a_script_of_any_entries_pulls_each_entry_only_after_the_one_before():  # consumed lazily
    pulled = []

    def entries():
        for n, t in enumerate((1.0, 1.0, 2.0, 0.5)):  # the last one late: it keeps its place, as given
            pulled.append(n)
            yield ScriptEntry(t, ROBOT, "cancel_task", raw=n)

    delivered = []
    for t, run in Script.of(entries()).runs():
        for inbound in run:
            delivered.append((t, inbound.raw, list(pulled)))
    assert delivered == [(1.0, 0, [0]), (1.0, 1, [0, 1]), (2.0, 2, [0, 1, 2]), (0.5, 3, [0, 1, 2, 3])]
