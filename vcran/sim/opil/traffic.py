"""How OPIL shows safety fields to its fleet manager (docs/contract.md §12): :class:`vcran.sim.traffic.Signals` for OPIL.

OPIL's RAN interface has no field for a protective field. A blocked robot shows it as a ``ran_error``
warning (code ``blocked``, naming the robot in its field: the body's ``report`` hook, which OPIL publishes),
and its ``current_motion`` shows what the body does: the velocity falls to zero as it brakes and stays there
while it waits; its task stays current (the motion is not done). Nothing is published when the field
clears: the robot drives on, and its velocity says so. With ``on_deadlock = "cancel"`` a deadlocked robot
stops for good where it stands (the body halts, why ``deadlock``): RanLogic reports it (``failed``, code
``deadlock``) and cancels the current task with reason ``deadlock``, as for a robot that stopped on its own
(docs/contract.md §4); queued tasks then start, so a fleet manager that re-plans cancels them.
"""

from __future__ import annotations

from collections.abc import Sequence

from vcran.sim.body import Body
from vcran.sim.holds import DEADLOCK, Halted

BLOCKED = "blocked"


class OpilTraffic:
    """:class:`vcran.sim.traffic.Signals` over the fleet's bodies (fleet order), OPIL's glue around them."""

    def __init__(self, bodies: Sequence[Body]) -> None:
        self.bodies = list(bodies)

    def blocked(self, robot: int, other: int) -> None:
        body = self.bodies[robot]
        body.report(BLOCKED, f"{self.bodies[other].id} entered the protective field: braking, waiting [§12]",
                    "warning")

    def unblocked(self, robot: int) -> None:
        pass  # the robot drives on: current_motion shows it

    def cancel(self, robot: int, others: Sequence[int]) -> None:
        names = ", ".join(self.bodies[r].id for r in others)
        self.bodies[robot].halt(Halted(DEADLOCK, f"deadlocked with {names}: stopped, task cancelled [§12]"))
