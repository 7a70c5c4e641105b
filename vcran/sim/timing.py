"""Event priorities: the documented tie order within one simulated instant (docs/contract.md §5, docs/determinism.md).

SimPy orders events by ``(time, priority, insertion)``. vcran gives each kind of event its own priority so
that what happens at one instant does not depend on when the event happened to be scheduled:

1. inbound messages, in arrival order, with everything they cause (hand-offs between processes through
   stores use SimPy's NORMAL priority, 1, so a cause's consequences finish before the next kind starts);
2. station production;
3. completions: an AGV reaching a point, AgvAction finishing an action, and the instants computed like
   them (a battery running out, two footprints starting to overlap; docs/contract.md §4);
4. injected faults, and the ends of their durations (a breakdown at the instant a leg ends finds the
   robot at the point; docs/contract.md §4), battery swaps;
5. R7 deadlines (so a task assembled exactly at its deadline is on time);
6. in a closed loop (docs/contract.md §9), the fleet manager's callbacks: first the robots' updates reaching it
   (so it decides on the freshest state), then jobs reaching it, then its own timers;
7. telemetry (it sees the state after everything else at that instant);
8. the end of the run (so the last instant is complete, telemetry included).

The manager's writes reach the RAN as inbound messages (1) after the link's latency, which is never
zero: a write is always delivered at a later instant than the callback that made it, so a recorded
trace replays in the same order (docs/determinism.md).
"""

from __future__ import annotations

from heapq import heappush
from typing import Any

import simpy
from simpy.events import Event

INBOUND = 1
PRODUCTION = 2
COMPLETION = 3
FAULT = 4
DEADLINE = 5
UPDATE = 6
JOB = 7
TIMER = 8
TELEMETRY = 9
END = 10

_new = object.__new__


class Environment(simpy.Environment):
    """``simpy.Environment`` whose ``now`` is read from a slot, not through a property.

    SimPy keeps the time in ``_now`` and hands it out through a Python property, a function call per read
    (about 600 machine instructions in plain Python, callgrind); a run reads it about 24 times per task
    (events, legs, inputs), 1% of its instructions (issue 30). Here ``_now`` is a slot and ``now`` the same
    slot's descriptor under a second name, so a read is an attribute load; SimPy's own code sets ``_now``
    as before. What the model builds when it is given no environment (live mode brings its own).
    """

    __slots__ = ("_now", "_active_proc")


Environment.now = Environment.__dict__["_now"]  # type: ignore[assignment,misc]
Environment.active_process = Environment.__dict__["_active_proc"]  # type: ignore[assignment,misc]  # likewise


def triggered(env: simpy.Environment, value: Any = None) -> Event:
    """A new event already triggered with ``value`` (not yet scheduled): what ``Event(env)`` followed by
    ``succeed``'s first two lines makes, its four attributes set directly (``Event.__init__`` is a Python call;
    a run makes about fourteen events a task, issue 30)."""
    event = _new(Event)
    event.env, event.callbacks, event._ok, event._value = env, [], True, value
    return event


def after(env: simpy.Environment, delay: float, priority: int) -> Event:
    """Like ``env.timeout(delay)`` but with an explicit priority (a Timeout is always NORMAL)."""
    if delay < 0:
        raise ValueError(f"negative delay {delay}")
    event = triggered(env)
    env.schedule(event, priority, delay)  # type: ignore[arg-type]  # any int orders the heap
    return event


def at(env: simpy.Environment, when: float, priority: int) -> Event:
    """An event at the absolute simulated time ``when``, exactly.

    ``env.timeout(when - env.now)`` would land on ``now + (when - now)``, which floating point does not
    always round back to ``when`` (0.1 + (0.3 - 0.1) != 0.3); a trace records times, and replay must hit
    them bit for bit. SimPy has no public absolute-time schedule, so this pushes onto the environment's
    queue the same ``(time, priority, id, event)`` entry that ``Environment.schedule`` pushes.
    """
    if when < env._now:  # type: ignore[attr-defined]  # ``now`` is a property: a Python call per event
        raise ValueError(f"time {when} is in the past (now {env.now})")
    event = _new(Event)  # triggered(env), written out: the most frequent event of a run
    event.env, event.callbacks, event._ok, event._value = env, [], True, None
    heappush(env._queue, (when, priority, next(env._eid), event))  # type: ignore[attr-defined,misc]
    return event
