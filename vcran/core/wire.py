"""What crosses the boundary between the simulation and a transport (docs/contract.md §1, §6), and the interface.

Inbound: an attribute of an entity changed, carrying either a decoded message (scripted, replay) or the
raw NGSI attribute (live, and scripts that exercise R12), which the RAN decodes. Outbound: a
:class:`Publish` of one attribute of one robot, or a :class:`Frame`, the whole fleet's ``current_motion``
at one telemetry tick as columns. The time is always the simulated time of the environment.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from vcran.core.slots import slot_init

if TYPE_CHECKING:  # a protocol's decoded message; typed as OPIL's, which every OPIL reader of these expects
    import numpy as np
    import simpy

    from vcran.core.opil.messages import Message


@slot_init
@dataclass(frozen=True, slots=True)
class Inbound:
    """``attribute`` of entity ``entity`` was written with ``message`` (decoded) or ``raw`` (NGSI JSON).

    ``wire``: the JSON text ``message`` was decoded from, where the script kept it (a VDA 5050 script's stamped
    messages): the trace writes it as it is rather than encoding the message again."""

    entity: str
    attribute: str
    message: Message | None = None
    raw: Any = None
    wire: bytes | None = field(default=None, compare=False, repr=False)


@slot_init
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

Deliver = Callable[[Inbound], None]


class Transport:
    """The transport interface: two methods and ``close()``, after httpx's ``BaseTransport``.

    A transport is attached to a running SimPy environment once. From then on it hands inbound messages
    to ``deliver`` at the simulated time they enter (a scripted transport schedules them; a live one
    stamps them with ``env.now`` when they arrive), and it receives every outbound message through
    :meth:`send`, already stamped with simulated time. Everything else (recording, verification) is a
    wrapper around another transport, never a flag inside one. It lives here, in the core, so that the
    simulation depends on the interface only; the implementations are in the top-level ``transports``
    package.
    """

    #: Whether :meth:`send` takes telemetry :class:`Frame` objects. Sampling the whole fleet every tick
    #: is a good part of a run's cost, so a transport that has no use for them says False and the RAN
    #: skips them (docs/contract.md §6: the trace's leg log, not the frames, determines the telemetry).
    wants_frames: bool = True
    #: Whether :meth:`send` takes VDA 5050 vehicles' ``visualization`` (§6.13), each vehicle's every telemetry
    #: period: most of what a fleet publishes, so a transport that has no use for them (a script, a replay, a
    #: closed loop whose master does not hear them) says False and the vehicles build none (docs/vda5050.md).
    wants_visualization: bool = True

    def attach(self, env: simpy.Environment, deliver: Deliver) -> None:
        """Start delivering inbound messages into ``env`` through ``deliver``."""
        raise NotImplementedError

    def send(self, out: Outbound) -> None:
        """Take one outbound message (a Publish or a telemetry Frame)."""
        raise NotImplementedError

    @property
    def exhausted(self) -> bool:
        """True once no further inbound message can come (lets a run stop when idle)."""
        return False

    def outage(self, robot: str, until: float) -> bool:
        """docs/contract.md §4 ``link_down``: cut ``robot``'s link from now until ``until`` on the transport's side, if
        the transport has a link of its own (a closed loop's :class:`vcran.sim.link.Link`), and say so.

        False (the default): the RAN holds the robot's messages itself (:meth:`vcran.sim.opil.ran.Ran.link_down`).
        """
        return False

    def close(self) -> None:
        """Release what the transport holds; called once, after the run."""
