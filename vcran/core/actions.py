"""What a robot's body does at a stop: the action kinds every protocol maps its own actions onto.

OPIL's ``RobotAction`` categories and the original VC-RAN's codes map here (:mod:`vcran.core.opil.messages`), and so do
VDA 5050's pick, drop and charging actions; stations (:mod:`vcran.core.stations`) and the body perform them.
"""

from __future__ import annotations

import enum


class ActionKind(enum.Enum):
    """What AgvAction does. The original VC-RAN's codes 0/1/2 and OPIL's categories 5/10/20 both map here."""

    DUMMY = "dummy"
    LOAD = "load"
    UNLOAD = "unload"
    #: vcran extension (docs/contract.md §4 Battery): refill the battery at a charger station.
    CHARGE = "charge"
