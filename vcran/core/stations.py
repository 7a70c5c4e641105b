"""Stations and what AgvAction does at them (docs/contract.md §4): pure bookkeeping of parts.

A station has a position, a reach (a circle around it, or an explicit polygon) and a part count, and may
produce parts at an interval. Load takes a part from the station in reach, unload puts one on it. The
transfer happens when the action's duration has passed, so a part produced during a load is taken.
shapely answers "is the AGV within reach"; it is imported on first use to keep start-up fast.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from vcran.core.actions import ActionKind


@dataclass(slots=True)
class Station:
    name: str
    x: float
    y: float
    reach: float = 1.0
    parts: int = 0
    capacity: int = 1_000_000
    #: Produce one part every ``produce_every`` seconds from ``produce_start`` (0 = never) ...
    produce_every: float = 0.0
    produce_start: float = 0.0
    #: ... at most ``produce_limit`` parts in all (0 = unlimited). A full station skips a production.
    produce_limit: int = 0
    area: tuple[tuple[float, float], ...] = ()
    #: A charging point (docs/contract.md §4): ``charge`` actions in its reach refill the battery.
    charger: bool = False
    produced: int = 0
    _shape: Any = field(default=None, repr=False)

    def within_reach(self, x: float, y: float) -> bool:
        """Inside the explicit polygon (shapely), else within ``reach`` of the position (exact circle)."""
        if not self.area:
            return math.hypot(self.x - x, self.y - y) <= self.reach
        if self._shape is None:
            from shapely.geometry import Polygon
            from shapely.prepared import prep

            self._shape = prep(Polygon(self.area))
        from shapely.geometry import Point

        return bool(self._shape.covers(Point(x, y)))

    def bounds(self) -> tuple[float, float, float, float]:
        if self.area:
            xs, ys = [p[0] for p in self.area], [p[1] for p in self.area]
            return min(xs), min(ys), max(xs), max(ys)
        return self.x - self.reach, self.y - self.reach, self.x + self.reach, self.y + self.reach

    def produce(self) -> bool:
        """One production tick; returns whether a part appeared."""
        if self.produce_limit and self.produced >= self.produce_limit:
            return False
        if self.parts >= self.capacity:
            return False
        self.parts += 1
        self.produced += 1
        return True

    @property
    def producing(self) -> bool:
        return self.produce_every > 0


@dataclass(frozen=True, slots=True)
class Outcome:
    ok: bool
    code: str = ""
    message: str = ""
    station: str = ""


class StationMap:
    """The stations with a uniform grid index, so finding the one in reach does not scan them all.

    Each station is filed under every grid cell its reach box touches; a query looks at one cell.
    """

    def __init__(self, stations: list[Station], cell: float | None = None) -> None:
        self.stations = stations
        sizes = [max(b[2] - b[0], b[3] - b[1]) for b in (s.bounds() for s in stations)]
        self.cell = cell or max([2.0, *sizes])
        self._grid: dict[tuple[int, int], list[int]] = {}
        for i, s in enumerate(stations):
            x0, y0, x1, y1 = s.bounds()
            for gx in range(math.floor(x0 / self.cell), math.floor(x1 / self.cell) + 1):
                for gy in range(math.floor(y0 / self.cell), math.floor(y1 / self.cell) + 1):
                    self._grid.setdefault((gx, gy), []).append(i)

    def nearest_in_reach(self, x: float, y: float, chargers: bool = False) -> Station | None:
        """The station in reach of ``(x, y)`` nearest to it (among chargers only, if asked); ties go to the
        first in scenario order."""
        best, best_d = None, math.inf
        for i in self._grid.get((math.floor(x / self.cell), math.floor(y / self.cell)), ()):
            s = self.stations[i]
            if chargers and not s.charger:
                continue
            d = math.hypot(s.x - x, s.y - y)
            if d < best_d and s.within_reach(x, y):
                best, best_d = s, d
        return best


def attempt(
    kind: ActionKind, x: float, y: float, carried: int, capacity: int, stations: StationMap,
    capable: frozenset[ActionKind],
) -> tuple[Outcome, Station | None]:
    """What one action at ``(x, y)`` would do, without doing it: its outcome and, for a load or unload that
    would succeed, the station it would move a part to or from (:func:`transfer` moves it). Apart, so that
    an action failed for another reason (an injected fault, docs/contract.md §4) moves nothing."""
    if kind not in capable:
        return Outcome(False, "action_not_capable", f"this robot is not configured to {kind.value}"), None
    if kind is ActionKind.DUMMY or kind is ActionKind.CHARGE:  # a charge's energy is the battery's part
        return Outcome(True), None
    station = stations.nearest_in_reach(x, y)
    where = f"at {x:.3f}, {y:.3f}"
    if station is None:
        return Outcome(False, "no_station_in_reach", f"{kind.value}: no station in reach {where}"), None
    if kind is ActionKind.LOAD:
        if station.parts <= 0:
            return Outcome(False, "load_no_part", f"load: station {station.name} has no part", station.name), None
        if carried >= capacity:
            return Outcome(False, "load_full", f"load: robot already carries {carried} of {capacity}", station.name), None
        return Outcome(True, station=station.name), station
    if carried <= 0:
        return Outcome(False, "unload_nothing_carried", f"unload: robot carries nothing, station {station.name}", station.name), None
    if station.parts >= station.capacity:
        return Outcome(False, "station_full", f"unload: station {station.name} is full", station.name), None
    return Outcome(True, station=station.name), station


def transfer(kind: ActionKind, station: Station, carried: int) -> int:
    """Move one part of a load or unload that :func:`attempt` found possible; the parts now carried."""
    if kind is ActionKind.LOAD:
        station.parts -= 1
        return carried + 1
    station.parts += 1
    return carried - 1


def area_problem(points: list[tuple[float, float]], x: float, y: float) -> str | None:
    """R12: why ``(x, y)`` is outside a non-empty motion area polygon, or None when it is inside."""
    if not points:
        return None
    if len(points) < 3:
        return f"motion_area has {len(points)} points; a polygon needs at least 3"
    from shapely import covers
    from shapely.geometry import Point, Polygon

    shape = Polygon(points)
    if not shape.is_valid:
        return "motion_area is not a valid polygon"
    if not covers(shape, Point(x, y)):
        return f"target {x}, {y} is outside its motion_area"
    return None
