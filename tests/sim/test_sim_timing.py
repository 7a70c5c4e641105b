"""vcran's use of SimPy internals (vcran/sim/timing.py), guarded: a SimPy release that changes its event
queue must fail here, loudly, not shift event order silently (docs/contract.md §5 tie order)."""

from __future__ import annotations

import simpy

from vcran.sim.timing import COMPLETION, DEADLINE, INBOUND, TELEMETRY, after, at


def test_event_queue_layout_is_what_at_pushes():
    env = simpy.Environment(0.0)
    env.timeout(1.0)
    when, priority, eid, event = env._queue[0]
    assert (when, priority) == (1.0, 1) and isinstance(eid, int) and isinstance(event, simpy.events.Event)


def test_at_lands_exactly_where_now_plus_delta_would_not():
    env = simpy.Environment(0.0)
    target = 0.1 * 7  # 0.7000000000000001, as a trace may record it
    seen = []

    def proc(env):
        yield at(env, 0.2, INBOUND)
        yield at(env, target, INBOUND)
        seen.append(env.now)

    env.process(proc(env))
    env.run()
    assert seen == [target]
    assert 0.2 + (target - 0.2) != target  # where env.timeout(target - now) would have landed


def test_priorities_order_one_instant_whatever_the_scheduling_order():
    env = simpy.Environment(0.0)
    order = []
    for name, priority in (("telemetry", TELEMETRY), ("deadline", DEADLINE), ("completion", COMPLETION),
                           ("inbound", INBOUND)):
        at(env, 5.0, priority).callbacks.append(lambda _, name=name: order.append(name))
    after(env, 5.0, COMPLETION).callbacks.append(lambda _: order.append("completion2"))
    env.run()
    assert order == ["inbound", "completion", "completion2", "deadline", "telemetry"]
