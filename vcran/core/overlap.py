"""The exact footprint test of collision detection (docs/contract.md §4): numpy, and shapely for concave footprints.

:mod:`vcran.core.collisions` decides which pairs of tracks could meet (plain Python: a grid of boxes);
this module answers when two tracks' footprints start or stop touching and where. It is imported only
when a pair's boxes overlap, so a fleet whose robots keep apart never loads numpy for it (start-up,
issue 14). See :mod:`vcran.core.collisions` for the method.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from vcran.core.collisions import COARSE, MAX_ROUNDS, MAX_SAMPLES, REFINE, TIME_TOL, Track
from vcran.core.motion import Leg
from vcran.core.sampling import leg_poses


class Moving(Protocol):
    """What :func:`first_change` samples: a robot's leg (or its pose at rest) and bounds on how far from its
    origin, and how fast, the shape it carries reaches: a :class:`Track`'s footprint, or a safety field
    (:class:`vcran.core.traffic.fields.FieldTrack`)."""

    @property
    def leg(self) -> Leg | None: ...
    @property
    def pose(self) -> tuple[float, float, float]: ...
    @property
    def radius(self) -> float: ...
    @property
    def drive(self) -> float: ...
    @property
    def speed(self) -> float: ...


#: Whether the shapes of two moving things meet at each of ``times``: :func:`touching`, or another test.
Meets = Callable[[Any, Any, np.ndarray], np.ndarray]


def poses(track: Moving, times: np.ndarray) -> np.ndarray:
    """``(len(times), 3)`` poses x, y, theta of ``track``."""
    if track.leg is None:
        out = np.empty((len(times), 3))
        out[:] = track.pose  # a tenth of np.broadcast_to's cost, which is Python
        return out
    return leg_poses(track.leg, times)


def shape_of(points: Iterable[tuple[float, float]]) -> np.ndarray:
    """A footprint as an ``(n, 2)`` array (its bounding radius is :attr:`Footprint.radius
    <vcran.core.collisions.Footprint.radius>`)."""
    return np.asarray(list(points), dtype=np.float64).reshape(-1, 2)


@dataclass(frozen=True, slots=True)
class Axes:
    """A convex footprint's edge normals in the robot frame, x and y components each ``(m, 1)``, and its own
    extent along each, ``low`` and ``high`` each ``(m, 1)``: shaped to broadcast against the other footprint's
    corners laid out ``(corners, samples)`` (:func:`_apart_along`)."""

    nx: np.ndarray
    ny: np.ndarray
    low: np.ndarray
    high: np.ndarray


def convex_axes(shape: np.ndarray) -> Axes | None:
    """The separating axes of ``shape`` if it is a valid convex polygon with an area, else None (shapely then).

    Convex, valid and with an area: corner by corner (a corner given twice in a row counts once), the
    boundary turns the same way or goes straight on (never back), turns at least once, and goes round
    exactly once (a pentagram turns one way at every corner, but twice round). Decided in numpy from the corners alone: shapely is
    imported (11 ms of a run's start-up) only for the footprints that need it, which most fleets have none
    of, and an area comparison with the convex hull would call a convex polygon concave when the two areas
    round apart in the last bit.
    """
    if len(shape) < 3:
        return None
    edges = np.roll(shape, -1, axis=0) - shape
    sides = edges[(edges != 0.0).any(axis=1)]  # a corner given twice in a row is one corner
    following = np.roll(sides, -1, axis=0)
    cross = sides[:, 0] * following[:, 1] - sides[:, 1] * following[:, 0]
    dot = np.einsum("ij,ij->i", sides, following)
    one_way = bool(np.all(cross >= 0.0) or np.all(cross <= 0.0)) and bool(np.any(cross != 0.0))
    if not one_way or np.any((cross == 0.0) & (dot <= 0.0)):
        return None
    if round(abs(float(np.arctan2(cross, dot).sum())) / (2.0 * math.pi)) != 1:
        return None
    normals = np.column_stack((-edges[:, 1], edges[:, 0]))
    own = normals @ shape.T  # (m, corners)
    return Axes(normals[:, 0:1], normals[:, 1:2], own.min(axis=1, keepdims=True), own.max(axis=1, keepdims=True))


def _corners(shape: np.ndarray, x: np.ndarray, y: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The corners of footprint ``shape`` at poses ``x, y, theta``: x and y, each ``(corners, len(x))``.

    Corners first, so that reductions over them (:func:`_apart_along`) run along the outer axis, which
    numpy does as a few elementwise operations on whole rows: along the inner axis of four corners each,
    ``max`` and ``min`` were a third of a contact test's time.
    """
    c, s = np.cos(theta), np.sin(theta)
    px, py = shape[:, 0:1], shape[:, 1:2]
    return x + px * c - py * s, y + px * s + py * c


def footprints(track: Track, poses: np.ndarray) -> np.ndarray:
    """The footprint polygons at ``poses`` (a shapely array)."""
    import shapely  # only for concave footprints and contact points (see convex_axes)

    xs, ys = _corners(track.shape, poses[:, 0], poses[:, 1], poses[:, 2])
    return shapely.polygons(np.stack((xs.T, ys.T), axis=-1))


def _apart_along(axes: Axes, pose: np.ndarray, other: Track, other_pose: np.ndarray) -> np.ndarray:
    """Whether some edge normal of the footprint with ``axes`` at ``pose`` separates ``other``'s, per sample.

    Works in that robot's frame, where its own extent along each normal is a constant.
    """
    x, y, theta = pose[:, 0], pose[:, 1], pose[:, 2]
    c, s = np.cos(theta), np.sin(theta)
    dx, dy = other_pose[:, 0] - x, other_pose[:, 1] - y
    # the other's corners in this robot's frame, (corners, samples); projected: (corners, normals, samples)
    xs, ys = _corners(other.shape, c * dx + s * dy, c * dy - s * dx, other_pose[:, 2] - theta)
    proj = axes.nx * xs[:, None, :] + axes.ny * ys[:, None, :]
    return ((proj.max(axis=0) < axes.low) | (proj.min(axis=0) > axes.high)).any(axis=0)


def _convex_touching(a: Track, b: Track, pa: np.ndarray, pb: np.ndarray) -> np.ndarray:
    """:func:`touching` for two convex footprints, by the separating axis theorem (numpy, no shapely).

    Two convex polygons are apart exactly when their projections on some edge normal of either are apart;
    projections that share an end count as touching, as shapely's ``intersects`` does.
    """
    assert a.axes is not None and b.axes is not None
    apart = _apart_along(a.axes, pa, b, pb)
    if not apart.any():  # close to a contact, as in a refinement: no sample to leave out
        return ~_apart_along(b.axes, pb, a, pa)
    rest = ~apart
    if rest.any():
        apart[rest] = _apart_along(b.axes, pb[rest], a, pa[rest])
    return ~apart


def touching(a: Track, b: Track, times: np.ndarray) -> np.ndarray:
    """Whether the footprints of ``a`` and ``b`` intersect (touching counts) at each of ``times``."""
    pa, pb = poses(a, times), poses(b, times)
    near = np.hypot(pa[:, 0] - pb[:, 0], pa[:, 1] - pb[:, 1]) <= a.radius + b.radius
    convex = a.axes is not None and b.axes is not None
    if convex and near.all():  # close all along, as in a refinement: no sample to leave out
        return _convex_touching(a, b, pa, pb)
    out = np.zeros(len(times), dtype=bool)
    if near.any():
        if convex:
            out[near] = _convex_touching(a, b, pa[near], pb[near])
        else:
            import shapely

            out[near] = shapely.intersects(footprints(a, pa[near]), footprints(b, pb[near]))
    return out


def first_change(
    a: Moving, b: Moving, t0: float, t1: float, resolution: float, want: bool, exact: bool = True,
    meets: Meets = touching,
) -> float | None:
    """The first instant in ``[t0, t1]`` at which "the footprints touch" becomes ``want``, or None.

    With ``exact`` false the first sample at which it holds is returned, at most one sampling step after
    the change (no refinement): enough where only the order of events matters, not the instant.
    ``meets`` replaces the footprint test (a safety field's: :mod:`vcran.core.traffic.intrusion`); the
    sampling, the skipping and the refinement are the same.
    """
    if t1 < t0:
        return None
    speed = a.speed + b.speed
    if speed <= 0.0 or t1 == t0:
        return t0 if bool(meets(a, b, np.array([t0]))[0]) == want else None
    span = t1 - t0 if math.isfinite(t1) else 0.0
    if span == 0.0:
        return t0 if bool(meets(a, b, np.array([t0]))[0]) == want else None
    step = max(resolution / speed, span / MAX_SAMPLES)
    times = t0 + step * np.arange(math.ceil(span / step) + 1)
    times[-1] = t1
    hits = np.flatnonzero(_touching_along(a, b, times, step, meets) == want)
    if not len(hits):
        return None
    k = int(hits[0])
    if k == 0:
        return t0
    if not exact:
        return float(times[k])
    return _refine(a, b, float(times[k - 1]), float(times[k]), want, meets)


def _touching_along(a: Moving, b: Moving, times: np.ndarray, step: float, meets: Meets) -> np.ndarray:
    """:func:`touching` at ``times`` (evenly ``step`` apart), skipping stretches where the robots are far apart.

    The robots' origins are first compared every ``COARSE`` samples: neither moves faster than its leg's
    peak speed, so where, at one end of a coarse stretch, they are further apart than their bounding
    radii plus what both can drive in the stretch, no sample inside can touch. Only the other stretches are
    sampled finely, at the same instants a full scan would use, so the answer is the full scan's.
    """
    n = len(times)
    out = np.zeros(n, dtype=bool)
    ends = np.arange(0, n - 1 + COARSE, COARSE).clip(max=n - 1)
    pa, pb = poses(a, times[ends]), poses(b, times[ends])
    reach = a.radius + b.radius + (a.drive + b.drive) * COARSE * step
    close = np.hypot(pa[:, 0] - pb[:, 0], pa[:, 1] - pb[:, 1]) <= reach * (1.0 + 1e-9) + 1e-9
    stretches = np.flatnonzero(close[:-1] & close[1:])  # n >= 2, so there are at least two ends
    if not len(stretches):
        return out
    need = np.zeros(n, dtype=bool)
    for m in stretches.tolist():
        need[ends[m] : ends[m + 1] + 1] = True
    out[need] = meets(a, b, times[need])
    return out


def _refine(a: Moving, b: Moving, lo: float, hi: float, want: bool, meets: Meets) -> float:
    """Narrow ``(lo, hi]`` (not ``want`` at ``lo``, ``want`` at ``hi``) to ``TIME_TOL``; return its end.

    Each round samples ``REFINE - 1`` instants inside the bracket in one vectorised call and keeps the gap
    before the first that is ``want``: the bracket shrinks ``REFINE``-fold a round, so a sampling step of
    tens of milliseconds reaches a nanosecond in about five calls (scalar bisection took about 25, each
    costing nearly as much as a call with 64 samples).
    """
    fractions = np.arange(1, REFINE) / REFINE
    for _ in range(MAX_ROUNDS):
        if hi - lo <= TIME_TOL:
            break
        inner = lo + (hi - lo) * fractions
        hits = np.flatnonzero(meets(a, b, inner) == want)
        if not len(hits):
            lo = float(inner[-1])
            continue
        k = int(hits[0])
        hi = float(inner[k])
        if k:
            lo = float(inner[k - 1])
    return hi


def contact_point(a: Track, b: Track, t: float) -> tuple[float, float]:
    """Where the footprints meet at ``t``: the centroid of their intersection (a corner, when they just touch)."""
    times = np.array([t])
    import shapely

    fa, fb = footprints(a, poses(a, times))[0], footprints(b, poses(b, times))[0]
    c = shapely.intersection(fa, fb).centroid
    if c.is_empty:  # not touching after all (the caller asked at a separation): midway between the robots
        pa, pb = poses(a, times)[0], poses(b, times)[0]
        return float(0.5 * (pa[0] + pb[0])), float(0.5 * (pa[1] + pb[1]))
    return float(c.x), float(c.y)
