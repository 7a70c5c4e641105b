"""A VDA 5050 scenario's script in the Yard (docs/vda5050.md, "VDA 5050 scenarios"): the scripted run, until
the simulation hosts VDA 5050 vehicles (issue 31's SimPy glue).

:class:`ScriptedMaster` plays the part a script plays in ``vcran run``: each message to its vehicle at its
time, as it is, hearing nothing back. The Yard produces no parts; :func:`produce` injects each station's
production at the times the simulation would.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from vcran.core.stations import Station
from vcran.core.vda5050.master import Master
from vcran.testing.vda5050.yard import Yard

if TYPE_CHECKING:  # types only: VDA 5050 imports nothing of OPIL's, which the scenario module still does
    from vcran.core.scenario import Scenario

__all__ = ["ScriptedMaster", "produce"]


class ScriptedMaster(Master):
    """Sends ``scenario``'s script (its ``message`` entries, stamped by the loader) to the vehicles at their
    times: a master that never listens."""

    def __init__(self, scenario: Scenario) -> None:
        self.scenario = scenario

    def on_start(self) -> None:
        serials = {r.id: r.serial_number for r in self.scenario.robots}
        for entry in self.scenario.script:
            if entry.message is None:
                raise ValueError(f"script entry at t = {entry.t:g}: a payload, which the Yard cannot send (it "
                                 "sends models, and decodes them as on the wire)")
            self.handle.call_at(entry.t, self.handle.send, serials[entry.robot], entry.message)


def produce(yard: Yard, until: float) -> None:
    """Each station of the Yard's scenario produces its parts up to ``until`` as the simulation does (docs/contract.md §4,
    :meth:`vcran.core.stations.Station.produce`: every ``produce_every`` seconds from ``produce_start``, a full
    station skipping its turn, at most ``produce_limit`` parts), injected into the Yard's stock."""
    for s in yard.scenario.stations:
        if s.produce_every <= 0:
            continue
        station = Station(s.id, s.position[0], s.position[1], capacity=s.capacity, produce_every=s.produce_every,
                          produce_limit=s.produce_limit)
        start = s.produce_start if s.produce_start is not None else s.produce_every
        k = 0
        while (t := start + k * s.produce_every) <= until:
            yard.call_at(t, _tick, yard, station)
            k += 1


def _tick(yard: Yard, station: Station) -> None:
    station.parts = yard.stock[station.name]  # what picks and drops left
    if station.produce():
        yard.stock[station.name] = station.parts
