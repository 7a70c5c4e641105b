"""The protocols a run can speak, and what the shared model asks of each one's SimPy glue (docs/protocols.md).

The shared :class:`~vcran.sim.model.Model` builds the bodies, stations, batteries, faults and collisions; a
protocol's *glue* gives each body its vehicle logic and process, routes the transport's messages to them and
publishes what its fleet manager hears. :data:`PROTOCOLS` names each glue by module path, imported when a run
asks for it: the shared modules import no protocol package (the import contracts in pyproject.toml), and this
table is the one place that names them.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol

from vcran.core.wire import Inbound, Transport

if TYPE_CHECKING:
    from vcran.sim.body import Body
    from vcran.sim.model import Model
    from vcran.sim.power import Level
    from vcran.sim.traffic import Signals

#: Protocol name -> the module of its glue, which has ``glue(model) -> Glue``.
PROTOCOLS: dict[str, str] = {
    "opil": "vcran.sim.opil.glue",
    "vda5050": "vcran.sim.vda5050.glue",
}


class Glue(Protocol):
    """A protocol's part of one run, in the order the model calls it."""

    def attach(self, body: Body) -> None:
        """Give ``body`` its vehicle logic and the process feeding it; set the body's hooks (vcran.sim.body)."""

    def connect(self, transport: Transport) -> None:
        """Route ``transport``'s messages to the logics and publish through it (nothing scheduled yet)."""

    def every_tick(self, then: Callable[[float], None]) -> None:
        """Call ``then(t)`` after each periodic publication of the fleet's state (the batteries' tick)."""

    def battery_states(self, t: float, levels: list[Level]) -> None:
        """Publish the battery levels that changed at ``t`` (:class:`vcran.sim.power.Power`)."""

    def link_down(self, body: Body, duration: float) -> None:
        """docs/contract.md §4 link_down: for ``duration`` the robot neither receives nor publishes."""

    def start(self, telemetry_period: float, description_period: float, after_tick: Callable[[], bool]) -> None:
        """Start the periodic publications; ``after_tick()`` after each says whether the run is over."""

    @property
    def deliver(self) -> Callable[[Inbound], None]:
        """The transport's entry point."""

    @property
    def links_down(self) -> bool:
        """Whether some robot's link is down (what it missed still waits)."""

    def idle(self) -> bool:
        """Whether every logic has nothing to do (a run ``until_idle`` may end)."""

    def errors(self, index: int) -> int:
        """The errors robot ``index``'s logic reported (summary.json)."""

    def traffic(self) -> Signals:
        """How the protocol shows safety fields' blocks and deadlocks (docs/contract.md §12; asked only when some robot
        has a field)."""


def glue(name: str) -> Callable[[Model], Glue]:
    """The glue factory of protocol ``name``."""
    try:
        path = PROTOCOLS[name]
    except KeyError:
        raise ValueError(f"unknown protocol {name!r}; known: {', '.join(sorted(PROTOCOLS))}") from None
    return importlib.import_module(path).glue  # type: ignore[no-any-return]
