"""How VDA 5050 shows safety fields to its master (docs/contract.md §12): :class:`vcran.sim.traffic.Signals` for VDA 5050.

A blocked vehicle reports ``safetyState.fieldViolation`` true (§6.10.6: "Protective field violation") until its
field is clear, each change an event that publishes a state; the body brakes and waits by itself, the order
stays as it is. With ``on_deadlock = "cancel"`` a deadlocked vehicle stops for good where it stands (the body
halts, why ``deadlock``): the Vehicle gives its order up as for any halt (docs/contract.md §4), with a ``deadlock``
warning in its state.
"""

from __future__ import annotations

from collections.abc import Sequence

from vcran.sim.holds import DEADLOCK, Halted
from vcran.sim.vda5050.node import FieldViolation, VehicleNode


class VdaTraffic:
    """:class:`vcran.sim.traffic.Signals` over the fleet's vehicles (fleet order)."""

    def __init__(self, nodes: Sequence[VehicleNode]) -> None:
        self.nodes = list(nodes)

    def blocked(self, robot: int, other: int) -> None:
        self.nodes[robot].inbox.put(FieldViolation(True))

    def unblocked(self, robot: int) -> None:
        self.nodes[robot].inbox.put(FieldViolation(False))

    def cancel(self, robot: int, others: Sequence[int]) -> None:
        names = ", ".join(self.nodes[r].id for r in others)
        self.nodes[robot].body.halt(Halted(DEADLOCK, f"deadlocked with {names}: stopped, order given up [§12]"))
