"""What crosses the boundary between the simulation and a transport (SPEC §1, §6).

Inbound: an attribute of an entity changed, carrying either a decoded message (scripted, replay) or the
raw NGSI attribute (live, and scripts that exercise R12), which the RAN decodes. Outbound: a
:class:`Publish` of one attribute of one robot, or a :class:`Frame`, the whole fleet's ``current_motion``
at one telemetry tick as columns. The time is always the simulated time of the environment.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from vcran.messages import Message


@dataclass(frozen=True, slots=True)
class Inbound:
    """``attribute`` of entity ``entity`` was written with ``message`` (decoded) or ``raw`` (NGSI JSON)."""

    entity: str
    attribute: str
    message: Message | None = None
    raw: Any = None


@dataclass(frozen=True, slots=True)
class Publish:
    """Write ``attribute`` of robot ``robot`` at simulated time ``t``."""

    t: float
    robot: str
    attribute: str
    message: Message


@dataclass(frozen=True, slots=True, eq=False)
class Frame:
    """``current_motion`` of every robot at tick ``t``: a (robots, 5) float64 array in fleet order."""

    t: float
    robots: tuple[str, ...]
    columns: np.ndarray

    #: Column order of :attr:`columns` and of the telemetry file.
    FIELDS = ("x", "y", "theta", "v", "w")


Outbound = Publish | Frame
