"""A robot's protective field (docs/contract.md §12): a rectangle ahead of its footprint whose length grows with speed.

Geometry. In the robot frame (x forward) the field spans ``x`` from the footprint's front (its largest
``x``) to that front plus the field's length, and ``y`` across the footprint's width (its smallest to its
largest ``y``) widened by ``side`` on each side. It moves with the robot and points the way the robot's
leg travels (:attr:`FieldTrack.heading`, the leg's :attr:`~vcran.core.motion.Leg.heading`), whatever the
robot's own heading: a leg turns in place first, then drives straight ahead (it never reverses), and while
it turns it does not translate, so what it can drive into is what lies ahead *in the direction it will
drive*. A robot turning to drive away from a robot in front of it is not blocked by that robot (turning,
its field would sweep over it and block it at once and for good); a robot standing where it is about to
drive blocks it before it turns. During a leg's last turn, to the goal's heading, the field keeps pointing
the way the robot came (cut to ``margin``: nothing is left to drive). A leg that does not travel (a turn in
place only) drives into nothing and has no field, as a robot at rest (:mod:`vcran.core.traffic.control`).

Length, one formula for the three usual kinds of field::

    length(v) = margin + reaction * v + v^2 / (2 * decel)     (the last term only with braking = true)

``margin`` alone is a fixed field; ``reaction`` adds the distance driven during a reaction time; the last
term is the braking distance at the robot's deceleration, so a robot whose field has ``margin > 0`` stops
at least ``margin`` short of an obstacle standing still (a robot coming the other way brakes too, and
both close the gap: each margin must exceed the other's braking distance, docs/robots.md "Head-on: how
long fields must be"). A turn in place has speed 0: the field keeps its length at rest.

The field never reaches more than ``margin`` past where the robot will stop: it is cut at the distance from
the robot to the end of its motion (every leg ends at rest) plus ``margin``. A robot slowing to its goal at
its deceleration has its braking distance left to drive, so there the cut is the field's own length
(less any reaction term): a robot coming the other way is seen as early near a goal as anywhere (cut at the goal itself, the field
of a robot about to arrive shrank to nothing, and a robot coming the other way drove into it). What stands
more than ``margin`` beyond the goal never blocks the arrival (else the robot would wait short of its goal,
its motion never done, for a robot it will never reach); what stands within it does, as it would block the
robot anywhere else.

A *waiting* field is the field of a robot that was blocked: its length is fixed at the length for the
speed the robot will drive on at (:attr:`vcran.core.traffic.braking.Braking.resume_speed`), or the speed
it braked from if that was higher, whatever its speed while braking and waiting. The robot drives on only when that field is clear, so a robot that starts
again does not find the obstacle in its field a moment later at the speed it gains (no stop-and-go within
an instant: the hysteresis of a real scanner's field switching).

:class:`FieldTrack` is a field along a robot's track (a leg, or a pose at rest): what
:mod:`vcran.core.traffic.intrusion` samples. Like :class:`vcran.core.collisions.Track` it knows how fast
any of its points can move (the sampling step follows from it) and the box it covers (the grid files it).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from vcran.core.collisions import BOX_PAD, Box
from vcran.core.motion import Leg


@dataclass(frozen=True, slots=True)
class FieldSpec:
    """A field as a scenario describes it (module docstring: the length formula). Metres and seconds."""

    margin: float
    reaction: float = 0.0
    braking: bool = True
    side: float = 0.0

    def __post_init__(self) -> None:
        for name in ("margin", "reaction", "side"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"a field's {name} must be a finite number >= 0, got {v!r}")

    def as_dict(self) -> dict[str, float | bool]:
        """The field as a scenario file writes it (``[robots.field]``, ``[traffic] field``)."""
        return {"margin": self.margin, "reaction": self.reaction, "braking": self.braking, "side": self.side}


@dataclass(frozen=True, slots=True)
class Field:
    """One robot's field: its rectangle in the robot frame and its length formula, ready to evaluate.

    ``front``: where it starts (x, robot frame); ``right``/``left``: its extent in y (right <= left);
    ``length(v) = margin + reaction * v + brake * v * v`` with ``brake`` = 1 / (2 decel), or 0.
    """

    front: float
    right: float
    left: float
    margin: float
    reaction: float
    brake: float

    @classmethod
    def of(cls, spec: FieldSpec, footprint: Iterable[tuple[float, float]], decel: float) -> Field:
        """The field ``spec`` gives a robot with ``footprint`` (robot frame) braking at ``decel`` m/s^2
        (0: it stops at once, so no braking distance). A robot without a footprint has its field start at
        its origin, ``2 * side`` wide."""
        points = list(footprint)
        front = max((x for x, _ in points), default=0.0)
        right = min((y for _, y in points), default=0.0) - spec.side
        left = max((y for _, y in points), default=0.0) + spec.side
        brake = 0.5 / decel if spec.braking and decel > 0 else 0.0
        return cls(float(front), float(right), float(left), spec.margin, spec.reaction, brake)

    def length(self, speed: float) -> float:
        return self.margin + self.reaction * speed + self.brake * speed * speed

    def reach(self, length: float) -> float:
        """The farthest any point of the field of ``length`` lies from the robot's origin."""
        return max(math.hypot(x, y) for x in (self.front, self.front + length) for y in (self.right, self.left))

    def corners(self, length: float) -> tuple[tuple[float, float], ...]:
        """The rectangle of ``length`` in the robot frame, counter-clockwise from its back right corner."""
        far = self.front + length
        return (self.front, self.right), (far, self.right), (far, self.left), (self.front, self.left)


@dataclass(slots=True)
class FieldTrack:
    """Robot ``index``'s field along ``leg`` (or at rest at ``pose``) until ``until``, pointing at ``heading``
    (radians, world frame: the direction the leg travels, module docstring).

    ``fixed``: the length of a waiting field (module docstring); None: the length follows the speed.
    ``goal``: where the robot's motion ends: the field is cut at the robot's distance to it plus the margin
    (None: not cut).
    Treat as immutable (a plain dataclass for the same reason as :class:`vcran.core.collisions.Track`).
    """

    index: int
    field: Field
    leg: Leg | None
    pose: tuple[float, float, float]
    until: float
    heading: float
    fixed: float | None = None
    goal: tuple[float, float] | None = None

    @property
    def longest(self) -> float:
        """The field's greatest length on this track."""
        if self.fixed is not None:
            return self.fixed
        return self.field.length(self.leg.peak if self.leg is not None else 0.0)

    @property
    def radius(self) -> float:
        """The farthest any point of the field gets from the robot's origin on this track."""
        return self.field.reach(self.longest)

    @property
    def drive(self) -> float:
        """Fastest the robot's origin moves on this track (m/s)."""
        return self.leg.peak if self.leg is not None else 0.0

    @property
    def speed(self) -> float:
        """Fastest any point of the field moves on this track (m/s): the robot's speed and the field's far
        edge growing while the robot speeds up or slows down (a ramp without a limit is a jump, which
        sampling sees on either side of it). The field does not turn with the robot's turns in place."""
        leg = self.leg
        if leg is None:
            return 0.0
        f = self.field
        growth = 0.0
        if self.fixed is None:
            ramp = max(leg.limits.accel, leg.limits.decel, 0.0)
            growth = (f.reaction + 2.0 * f.brake * leg.peak) * ramp
        return leg.peak + growth

    def box(self, t0: float = -math.inf, t1: float = math.inf) -> Box:
        """A bounding box of the field between ``t0`` and ``t1`` (see :meth:`vcran.core.collisions.Track.box`)."""
        r = self.radius + BOX_PAD
        leg = self.leg
        if leg is None:
            x, y, _ = self.pose
            return x - r, y - r, x + r, y + r
        if t0 == -math.inf and t1 == math.inf:
            xa, ya, xb, yb = leg.x0, leg.y0, leg.x1, leg.y1
        else:
            (xa, ya, *_), (xb, yb, *_) = leg.pose_at(t0), leg.pose_at(t1)
        return min(xa, xb) - r, min(ya, yb) - r, max(xa, xb) + r, max(ya, yb) + r


def driving(index: int, field: Field, leg: Leg) -> FieldTrack:
    """The field of robot ``index`` driving ``leg``: its length follows the speed, cut ``margin`` past the
    leg's end, pointing the way the leg travels (also while it turns in place)."""
    return FieldTrack(index, field, leg, (leg.x0, leg.y0, leg.theta0), leg.t_end, leg.heading, goal=(leg.x1, leg.y1))


def waiting(index: int, field: Field, speed: float, leg: Leg | None, pose: tuple[float, float, float],
            goal: tuple[float, float] | None = None, heading: float | None = None) -> FieldTrack:
    """The waiting field of robot ``index``, blocked: the length for ``speed`` (the speed it will drive on
    at), along its braking ``leg`` or at rest at ``pose`` (``leg`` None), cut ``margin`` past ``goal`` (the
    end of the motion it will drive on; None: not cut), pointing at ``heading``: the way the braked leg
    travels, so a robot blocked before or during its first turn waits for what lies where it will drive
    (None: the way ``pose`` faces)."""
    until = leg.t_end if leg is not None else math.inf
    toward = pose[2] if heading is None else heading
    return FieldTrack(index, field, leg, pose, until, toward, fixed=field.length(speed), goal=goal)
