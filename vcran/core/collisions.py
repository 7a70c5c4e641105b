"""Footprint collisions (docs/contract.md §4): when do two robots' footprints start (or stop) overlapping, and where.

A robot's *track* is what it does until its next change: a leg (:class:`vcran.core.motion.Leg`, poses
closed-form in time) or a rest pose. For two tracks, :func:`first_change` samples both at a step chosen so
that no point of either footprint moves more than ``resolution`` metres between samples (the documented
spatial resolution; the temporal one follows from the robots' speeds), skips stretches where the robots'
origins are too far apart to meet, discards the samples whose bounding circles are apart (numpy), tests the
rest exactly (convex footprints by separating axes in numpy, others as shapely polygons), and refines the
first sample that changed to ``TIME_TOL`` in a few vectorised rounds of ``REFINE`` samples. Contacts that
begin and end between two samples are missed; at 0.05 m that is a graze thinner than 5 cm.

Finding *which* pairs to test is :class:`Grid`'s job: a uniform grid over the floor, each robot filed
under the cells its track's bounding box touches, so a robot meets only its neighbours and the cost grows
with the fleet, not with its square. That part is plain Python; the exact test is in
:mod:`vcran.core.overlap` (numpy, shapely), imported only once two boxes overlap, so a fleet whose robots
keep apart never loads numpy for it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from vcran.core.motion import Leg

if TYPE_CHECKING:
    import numpy as np

    from vcran.core.overlap import Axes

#: Contact instants are refined to this many seconds.
TIME_TOL = 1e-9
#: Metres added to a track's box so that rounding in the pose formulas cannot put a sample outside it.
BOX_PAD = 1e-6
#: At most this many refinement rounds (a bracket at instants too large to split to ``TIME_TOL`` stops there).
MAX_ROUNDS = 16
#: A scan first compares the robots' origins every this many samples (see :func:`vcran.core.overlap._touching_along`).
COARSE = 32
#: Samples per refinement round (see :func:`vcran.core.overlap._refine`).
REFINE = 64
#: At most this many samples per pair test (the step grows for very long overlaps of slow pairs).
MAX_SAMPLES = 100_000

#: A box: min x, min y, max x, max y.
Box = tuple[float, float, float, float]
#: The cells a box touches, ``(gx0, gy0, gx1, gy1)``: grid columns ``gx0..gx1``, rows ``gy0..gy1``.
Span = tuple[int, int, int, int]
#: A cell's key is ``gx * STRIDE + gy``, one int: cheaper to make and hash than the tuple ``(gx, gy)`` on a
#: path taken for every leg a robot starts (issue 14). Rows more than ``STRIDE / 2`` cells from the origin
#: (4e10 m at 20 m cells) would share keys with others: that only makes robots neighbours that are not (the
#: box test sets them apart), never hides one.
STRIDE = 1 << 32


class Footprint:
    """A robot's footprint: its corners in the robot frame and its bounding radius around the origin (plain
    Python: the grid's boxes need only the radius), with the ``(n, 2)`` array and, for a convex polygon,
    the separating axes made on first use by the exact test (:mod:`vcran.core.overlap`).

    ``convex=False`` makes the exact test treat the footprint as a general polygon (shapely) even when it
    is convex. The radius is ``math.hypot``'s: a bound for the broad phase, which the exact test confirms.
    """

    __slots__ = ("points", "radius", "_convex", "_shape", "_axes")

    def __init__(self, points: Iterable[tuple[float, float]], convex: bool | None = None) -> None:
        self.points = tuple((float(x), float(y)) for x, y in points)
        self.radius = max((math.hypot(x, y) for x, y in self.points), default=0.0)
        self._convex = convex
        self._shape: np.ndarray | None = None
        self._axes: Axes | None | bool = False  # False: not decided yet

    @property
    def shape(self) -> np.ndarray:
        if self._shape is None:
            from vcran.core.overlap import shape_of

            self._shape = shape_of(self.points)
        return self._shape

    @property
    def axes(self) -> Axes | None:
        """The separating axes if the footprint is a valid convex polygon (and not declared otherwise)."""
        if self._axes is False:
            from vcran.core.overlap import convex_axes

            self._axes = convex_axes(self.shape) if self._convex is not False else None
        return self._axes  # type: ignore[return-value]


@dataclass(slots=True)
class Track:
    """Robot ``index``'s ``footprint`` on ``leg``, or at rest at ``pose``.

    Treat it as immutable. It is not a frozen dataclass because one is made on every leg start and stop,
    and a frozen dataclass's ``__init__`` (a ``object.__setattr__`` call per field) costs four times a
    plain one's (issue 14).
    """

    index: int
    footprint: Footprint
    leg: Leg | None
    pose: tuple[float, float, float]
    until: float  # the track holds until this instant (a leg's end; inf at rest)

    @property
    def radius(self) -> float:
        return self.footprint.radius

    @property
    def shape(self) -> np.ndarray:
        return self.footprint.shape

    @property
    def axes(self) -> Axes | None:
        return self.footprint.axes

    @property
    def drive(self) -> float:
        """Fastest the robot's origin moves on this track (m/s): it turns in place."""
        return self.leg.peak if self.leg is not None else 0.0

    @property
    def speed(self) -> float:
        """Fastest any footprint point moves on this track (m/s)."""
        leg = self.leg
        if leg is None:
            return 0.0
        return leg.peak + self.radius * max(abs(leg.rate1), abs(leg.rate2))

    def box(self, t0: float = -math.inf, t1: float = math.inf) -> Box:
        """A bounding box of everything this track covers between ``t0`` and ``t1`` (min x, min y, max x, max y).

        A leg drives along one straight segment, never back, and turns in place, so the part of it between
        two instants lies between the positions at those instants (padded by :data:`BOX_PAD` against
        rounding).
        """
        r = self.footprint.radius
        leg = self.leg
        if leg is None:
            x, y, _ = self.pose
            return x - r, y - r, x + r, y + r
        if t0 == -math.inf and t1 == math.inf:  # the whole leg: it spans its start and its point
            xa, ya, xb, yb = leg.x0, leg.y0, leg.x1, leg.y1
        else:
            (xa, ya, *_), (xb, yb, *_) = leg.pose_at(t0), leg.pose_at(t1)
        if xb < xa:  # ordered by hand: min() and max() were a third of this method's cost (issue 14)
            xa, xb = xb, xa
        if yb < ya:
            ya, yb = yb, ya
        r += BOX_PAD
        return xa - r, ya - r, xb + r, yb + r


class Grid:
    """Robots filed by the grid cells their track's box touches (see the module docstring).

    A robot is filed under a :data:`Span` of cells; the grid maps each cell's key (:data:`STRIDE`) to the
    robots filed under it, and keeps with each robot's span those cells' sets of robots.
    """

    def __init__(self, cell: float) -> None:
        self.cell = cell
        self.cells: dict[int, set[int]] = {}
        self.filed: dict[int, tuple[Span, list[set[int]]]] = {}

    def file(self, index: int, box: Box) -> list[int]:
        """File ``index`` under ``box``; return the other robots sharing one of its cells, in index order.

        When ``box`` lies in cells the robot is already filed under (a robot coming to rest at the end of its
        leg), the filing is kept, and so are the neighbours it gives: a superset only costs a box test
        later, and re-filing on every leg end would double the grid's work. A robot alone in its cells (two
        calls in three at 1000 robots) is answered without building a set of neighbours.
        """
        c = self.cell
        x0, y0, x1, y1 = box
        span = gx0, gy0, gx1, gy1 = math.floor(x0 / c), math.floor(y0 / c), math.floor(x1 / c), math.floor(y1 / c)
        old = self.filed.get(index)
        if old is None:
            members = self._refile(index, None, span)
        else:
            o = old[0]  # still within the cells it is filed under? (this runs at every leg start and end)
            members = old[1] if o[0] <= gx0 and o[1] <= gy0 and gx1 <= o[2] and gy1 <= o[3] else self._refile(index, o, span)
        if max(map(len, members)) == 1:  # alone in every cell (no Python-level loop for the common case)
            return []
        near = set().union(*(m for m in members if len(m) > 1))
        near.discard(index)
        return sorted(near)

    def _refile(self, index: int, old: Span | None, span: Span) -> list[set[int]]:
        """Move ``index`` from the cells of ``old`` to those of ``span``; return the sets of the latter.

        The cells in both are left as they are: a robot starting a leg from where it rests usually keeps
        its own cell, which re-filing from scratch would empty, drop and make anew.
        """
        cells = self.cells
        filed = []
        for key in _keys(span):
            members = cells.get(key)
            if members is None:
                members = cells[key] = {index}
            else:
                members.add(index)
            filed.append(members)
        self.filed[index] = span, filed
        if old is None:
            return filed
        gx0, gy0, gx1, gy1 = span
        for gx in range(old[0], old[2] + 1):
            for gy in range(old[1], old[3] + 1):
                if gx0 <= gx <= gx1 and gy0 <= gy <= gy1:
                    continue
                key = gx * STRIDE + gy
                members = cells[key]
                members.discard(index)
                if not members:
                    del cells[key]
        return filed


def _keys(span: Span) -> list[int]:
    gx0, gy0, gx1, gy1 = span
    return [gx * STRIDE + gy for gx in range(gx0, gx1 + 1) for gy in range(gy0, gy1 + 1)]


def apart(a: Box, b: Box) -> bool:
    """Whether two boxes are apart (boxes that share an edge or a corner are not)."""
    return a[2] < b[0] or b[2] < a[0] or a[3] < b[1] or b[3] < a[1]
