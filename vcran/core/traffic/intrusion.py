"""When another robot's footprint enters a robot's safety field, and when it leaves (docs/contract.md §12): numpy.

Computed, not stepped, exactly as first contact between footprints is (:mod:`vcran.core.overlap`, whose
sampling this reuses with another test): both tracks are sampled so that no point of the field (whose far
edge also moves as the field grows or shrinks with speed) nor of the other footprint moves more than
``resolution`` metres between samples; stretches where the two origins are too far apart to meet are
skipped; the first sample whose answer changed is refined to 1 ns. An intrusion that begins and ends
between two samples (thinner than the resolution) is missed, as a graze is by collision detection.

The test at one instant: the field is a rectangle in its robot's frame (turned to the way its leg
travels) whose length depends on the speed at that instant (:class:`~vcran.core.traffic.fields.Field`). A convex footprint is tested by the
separating axis theorem in numpy (the rectangle's two axes in its robot's frame, the footprint's edge
normals in the other's frame); any other footprint as shapely polygons. Touching counts as inside, as it
counts as contact. A robot without a footprint (``footprint = []``) never enters a field.

Imported only where a field's box meets another robot's (:mod:`vcran.core.traffic.watch`), like
:mod:`vcran.core.overlap`.
"""

from __future__ import annotations

import numpy as np

from vcran.core.collisions import Track
from vcran.core.overlap import _corners, first_change, footprints, poses
from vcran.core.sampling import sample_leg
from vcran.core.traffic.fields import FieldTrack


def first_entry(field: FieldTrack, other: Track, t0: float, t1: float, resolution: float) -> float | None:
    """The first instant in ``[t0, t1]`` at which ``other``'s footprint is in ``field`` (``t0`` if it is
    already), or None."""
    return first_change(field, other, t0, t1, resolution, want=True, meets=inside)


def first_exit(field: FieldTrack, other: Track, t0: float, t1: float, resolution: float) -> float | None:
    """The first instant in ``[t0, t1]`` at which ``other``'s footprint is out of ``field`` (``t0`` if it
    is already), or None."""
    return first_change(field, other, t0, t1, resolution, want=False, meets=inside)


def states(field: FieldTrack, times: np.ndarray) -> np.ndarray:
    """``(len(times), 4)``: the field's robot's ``x, y``, the field's heading (the way its leg travels, not
    the robot's heading while it turns: vcran.core.traffic.fields) and the field's length at each of
    ``times`` (cut at the robot's distance to its goal plus the margin)."""
    out = np.empty((len(times), 4))
    leg = field.leg
    if leg is None:
        out[:, :2] = field.pose[:2]
        speeds = np.zeros(len(times))
    else:
        sampled = sample_leg(leg, times)
        out[:, :2] = sampled[:, :2]
        speeds = sampled[:, 3]
    out[:, 2] = field.heading
    if field.fixed is not None:
        out[:, 3] = field.fixed
    else:
        f = field.field
        out[:, 3] = f.margin + f.reaction * speeds + f.brake * speeds * speeds
    if field.goal is not None:
        left = np.hypot(field.goal[0] - out[:, 0], field.goal[1] - out[:, 1])
        np.minimum(out[:, 3], left + field.field.margin, out=out[:, 3])
    return out


def inside(field: FieldTrack, other: Track, times: np.ndarray) -> np.ndarray:
    """Whether ``other``'s footprint meets ``field`` (touching counts) at each of ``times``."""
    out = np.zeros(len(times), dtype=bool)
    if not other.footprint.points:
        return out
    own, theirs = states(field, times), poses(other, times)
    near = np.hypot(own[:, 0] - theirs[:, 0], own[:, 1] - theirs[:, 1]) <= field.radius + other.radius
    if not near.any():
        return out
    own, theirs = own[near], theirs[near]
    if other.axes is not None:
        out[near] = ~_apart(field, own, other, theirs)
    else:
        import shapely  # concave footprints only (see vcran.core.overlap.convex_axes)

        out[near] = shapely.intersects(_rectangles(field, own), footprints(other, theirs))
    return out


def _apart(field: FieldTrack, own: np.ndarray, other: Track, theirs: np.ndarray) -> np.ndarray:
    """Whether some axis separates the field from ``other``'s convex footprint, per sample."""
    f = field.field
    x, y, theta, length = own[:, 0], own[:, 1], own[:, 2], own[:, 3]
    c, s = np.cos(theta), np.sin(theta)
    dx, dy = theirs[:, 0] - x, theirs[:, 1] - y
    # the other robot's pose in the field's robot frame, where the field is an axis-aligned rectangle
    ox, oy, turn = c * dx + s * dy, c * dy - s * dx, theirs[:, 2] - theta
    xs, ys = _corners(other.shape, ox, oy, turn)  # (corners, samples)
    far = f.front + length
    apart = (xs.max(axis=0) < f.front) | (xs.min(axis=0) > far) | (ys.max(axis=0) < f.right) | (ys.min(axis=0) > f.left)
    rest = ~apart
    if rest.any():
        axes = other.axes
        assert axes is not None
        ox, oy, turn, far = ox[rest], oy[rest], turn[rest], far[rest]
        n = len(ox)
        # the field's corners (back right, far right, far left, back left), then in the other robot's frame
        rx = np.stack((np.full(n, f.front), far, far, np.full(n, f.front)))
        ry = np.stack((np.full(n, f.right), np.full(n, f.right), np.full(n, f.left), np.full(n, f.left)))
        co, so = np.cos(turn), np.sin(turn)
        px, py = rx - ox, ry - oy
        u, w = co * px + so * py, co * py - so * px
        proj = axes.nx * u[:, None, :] + axes.ny * w[:, None, :]  # (corners, normals, samples)
        apart[rest] = ((proj.max(axis=0) < axes.low) | (proj.min(axis=0) > axes.high)).any(axis=0)
    return apart


def _rectangles(field: FieldTrack, own: np.ndarray) -> np.ndarray:
    """The field's rectangles at ``own`` (x, y, theta, length), as a shapely array."""
    import shapely

    f = field.field
    n = len(own)
    far = f.front + own[:, 3]
    local_x = np.stack((np.full(n, f.front), far, far, np.full(n, f.front)), axis=1)  # (samples, 4)
    local_y = np.tile(np.array([f.right, f.right, f.left, f.left]), (n, 1))
    c, s = np.cos(own[:, 2])[:, None], np.sin(own[:, 2])[:, None]
    xs = own[:, 0:1] + local_x * c - local_y * s
    ys = own[:, 1:2] + local_x * s + local_y * c
    return shapely.polygons(np.stack((xs, ys), axis=-1))
