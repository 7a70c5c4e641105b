"""Deadlock (docs/contract.md §12): robots stopped on one another in a cycle, or a robot blocked longer than a bound.

Input: who is blocked by whom since when (a *wait-for* graph: robot ``r`` waits for every robot in its
safety field, :mod:`vcran.core.traffic.watch`), and which blocked robots have come to rest. A blocked robot
drives on only when its field holds nobody (an AND wait: it needs every one of them gone).

A cycle counts only among robots at rest. A robot that is still braking moves on along its leg and may
leave the field it is in (two robots crossing at right angles can each catch the other and yet part), so
a cycle of robots that are still braking may dissolve; once every robot of a cycle stands still, none of
them will move again (each waits for the next, which waits too): that is a deadlock, at the instant the
last of them stopped (or the last wait among them began). Only a change from outside ends it: a fleet
manager's cancel, a fault, the scenario cancelling their tasks with reason ``deadlock``.

Reports are deterministic: a cycle is the shortest one through the robot whose stop (or wait) closed it,
found breadth first with robots taken in fleet order, and told in wait order from its first robot in fleet
order (``(3, 7, 5)``: 3 waits for 7, 7 for 5, 5 for 3). A robot is reported once per spell of being
blocked (the spell ends when its field is clear): by the first cycle it is found in, or past the bound.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

CYCLE, BOUND = "cycle", "bound"


@dataclass(frozen=True, slots=True)
class Deadlock:
    """At ``t``: the robots of a cycle (``kind`` "cycle", ``since`` = ``t``), or one robot blocked since
    ``since`` for longer than the bound (``kind`` "bound"; ``waiting_for``: the robots in its field)."""

    t: float
    kind: str
    robots: tuple[int, ...]
    since: float
    waiting_for: tuple[int, ...] = ()


class WaitFor:
    """The wait-for graph and its deadlocks (module docstring). Robots are fleet indices.

    ``bound``: seconds a robot may stay blocked before it is reported (None: never).
    """

    def __init__(self, bound: float | None = None) -> None:
        if bound is not None and not bound > 0:
            raise ValueError(f"a deadlock bound must be positive, got {bound!r}")
        self.bound = bound
        self.waits: dict[int, set[int]] = {}  # robot -> the robots it waits for (non-empty)
        self.since: dict[int, float] = {}  # robot -> when its current spell of being blocked began
        self.at_rest: set[int] = set()  # blocked robots that have stopped
        self.reported: set[int] = set()  # robots reported in their current spell

    def block(self, robot: int, other: int, t: float) -> Deadlock | None:
        """``robot`` waits for ``other`` from ``t``: a deadlock if that closes a cycle of robots at rest."""
        if robot not in self.waits:
            self.waits[robot] = set()
            self.since[robot] = t
        self.waits[robot].add(other)
        if robot in self.at_rest and other in self.at_rest:
            return self._cycle(robot, t)
        return None

    def unblock(self, robot: int, other: int) -> None:
        """``robot`` no longer waits for ``other``; with nobody left it is no longer blocked."""
        waits = self.waits.get(robot)
        if waits is None:
            return
        waits.discard(other)
        if not waits:
            self.clear(robot)

    def clear(self, robot: int) -> None:
        """``robot`` waits for nobody (its field is clear, or it was stopped or given up from outside)."""
        self.waits.pop(robot, None)
        self.since.pop(robot, None)
        self.at_rest.discard(robot)
        self.reported.discard(robot)

    def stopped(self, robot: int, t: float) -> Deadlock | None:
        """Blocked ``robot`` has come to rest at ``t``: a deadlock if that closes a cycle of robots at rest."""
        if robot not in self.waits:
            return None
        self.at_rest.add(robot)
        return self._cycle(robot, t)

    def deadline(self, robot: int) -> float | None:
        """When ``robot``, blocked and not yet reported, will have been blocked for the bound (None: never)."""
        if self.bound is None or robot not in self.since or robot in self.reported:
            return None
        return self.since[robot] + self.bound

    def overdue(self, robot: int, t: float) -> Deadlock | None:
        """At ``t`` (a :meth:`deadline`): ``robot`` blocked for the bound, or None if its spell ended since."""
        due = self.deadline(robot)
        if due is None or due > t:
            return None
        self.reported.add(robot)
        return Deadlock(t, BOUND, (robot,), self.since[robot], tuple(sorted(self.waits[robot])))

    def _cycle(self, robot: int, t: float) -> Deadlock | None:
        """The shortest cycle through ``robot`` among robots at rest (breadth first, in fleet order)."""
        parent: dict[int, int] = {}
        queue = deque([robot])
        while queue:
            here = queue.popleft()
            for nxt in sorted(self.waits.get(here, ())):
                if nxt not in self.at_rest:
                    continue
                if nxt == robot:
                    cycle = [here]
                    while cycle[-1] != robot:
                        cycle.append(parent[cycle[-1]])
                    cycle.reverse()  # robot, ..., here: each waits for the next, here for robot
                    return self._report(cycle, t)
                if nxt not in parent:
                    parent[nxt] = here
                    queue.append(nxt)
        return None

    def _report(self, cycle: list[int], t: float) -> Deadlock | None:
        if all(r in self.reported for r in cycle):
            return None
        self.reported.update(cycle)
        first = cycle.index(min(cycle))
        return Deadlock(t, CYCLE, tuple(cycle[first:] + cycle[:first]), t)
