"""How OPIL shows safety fields to its fleet manager (SPEC §12): :class:`vcran.sim.traffic.Signals` for OPIL.

OPIL's RAN interface has no field for a protective field. A blocked robot shows it as a ``ran_error``
warning (code ``blocked``, naming the robot in its field), and its ``current_motion`` shows what the body
does: the velocity falls to zero as it brakes and stays there while it waits; its task stays current (the
motion is not done). Nothing is published when the field clears: the robot drives on, and its velocity says
so. With ``on_deadlock = "cancel"`` a deadlocked robot stops for good where it stands, RanLogic reports it
(``failed``, code ``deadlock``) and cancels the current task with reason ``deadlock`` (R6's path for a robot
that stopped on its own, SPEC §4); queued tasks then start, so a fleet manager that re-plans sends cancels.
"""

from __future__ import annotations

from collections.abc import Sequence

from vcran.core.opil.effects import Reason
from vcran.sim.robot import Halted, RobotNode

BLOCKED, DEADLOCK = "blocked", "deadlock"


class OpilTraffic:
    """:class:`vcran.sim.traffic.Signals` over the fleet's OPIL robots (fleet order)."""

    def __init__(self, robots: Sequence[RobotNode]) -> None:
        self.robots = list(robots)

    def blocked(self, robot: int, other: int) -> None:
        node = self.robots[robot]
        node.report(BLOCKED, f"{self.robots[other].id} entered the protective field: braking, waiting [§12]")

    def unblocked(self, robot: int) -> None:
        pass  # the robot drives on: current_motion shows it

    def cancel(self, robot: int, others: Sequence[int]) -> None:
        message = f"deadlocked with {', '.join(self.robots[r].id for r in others)}: stopped, task cancelled [§12]"
        self.robots[robot].halt(Halted(Reason.DEADLOCK, DEADLOCK, message))
