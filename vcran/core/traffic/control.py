"""What robots do about their safety fields (docs/contract.md §12): brake, wait, drive on; blocks and deadlocks.

:class:`Traffic` is a pure state machine for the whole fleet, shaped like the rest of vcran's logic: inputs
carry ``now``, outputs are effects as data. The SimPy body (issue 32's integration, after issue 30) only
turns effects into actions and schedules, and calls back:

=====================  ==================================================================================
input (body → Traffic)  when
=====================  ==================================================================================
``drive(i, leg, now)``  robot ``i`` starts a leg (a motion, or a held leg resumed), not one Traffic gave it
``rest(i, pose, now)``  robot ``i`` rests without driving on (its leg ended, a hold, a halt, a cancel)
``due(change, now)``    at ``change.t`` of a :class:`Predicted` effect
``braked(i, spell, now)``  at ``t`` of a :class:`Wake` of kind ``braked``
``overdue(i, now)``     at ``t`` of a :class:`Wake` of kind ``bound``
=====================  ==================================================================================

=====================  ==================================================================================
effect (Traffic → body)  what the body does
=====================  ==================================================================================
:class:`Predicted`      schedule ``due(change)`` at ``change.t`` (stale ones cost a no-op)
:class:`Wake`           schedule ``braked`` or ``overdue`` at ``t``
:class:`Brake`          the running leg ends now (``FleetKinematics.stop``); the braked stretch
                        ``braking.stop`` is driven if not None (``FleetKinematics.start``, then ``finish``
                        at its end); its motion is not done: the robot waits for :class:`DriveOn`
:class:`DriveOn`        drive ``leg`` from now (the rest of the braked motion; its end completes it)
:class:`BlockedBy`      event ``blocked`` naming ``other``; OPIL: zero velocity and a ``ran_error``
                        warning; VDA 5050: ``safetyState.fieldViolation`` true
:class:`Unblocked`      event ``unblocked``; VDA 5050: ``fieldViolation`` false
:class:`Deadlocked`     event ``deadlock`` naming the robots; the scenario goes on or cancels their tasks
                        with reason ``deadlock`` (then ``rest`` for each)
=====================  ==================================================================================

Effects come in the order the body should apply them. A robot is blocked when a robot enters its empty
field: it brakes at once (:mod:`vcran.core.traffic.braking`), its field becomes a waiting field (fixed at
the length for the speed it will drive on at: :mod:`vcran.core.traffic.fields`), and it drives on from
rest when that field is clear and it has stopped, whichever comes last. ``blocked``/``unblocked`` pair up:
a blocked robot given a new leg or rest from outside is ``unblocked`` then, so a robot's blocked time is
the sum of its intervals. Robots with no field (``None``) never block, and are seen in others' fields.
A field points the way its robot's leg travels, also while the robot turns in place to start it, and a
waiting field the way the braked leg did; a leg that does not travel (a turn in place only) has no field
(:mod:`vcran.core.traffic.fields`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from vcran.core.collisions import Footprint, Track
from vcran.core.motion import Leg
from vcran.core.traffic.braking import Braking, brake
from vcran.core.traffic.deadlock import Deadlock, WaitFor
from vcran.core.traffic.fields import Field, FieldTrack, driving, waiting
from vcran.core.traffic.watch import Change, FieldWatch

BRAKED, BOUND = "braked", "bound"
Pose = tuple[float, float, float]


@dataclass(frozen=True, slots=True)
class Predicted:
    change: Change


@dataclass(frozen=True, slots=True)
class Wake:
    """Call ``braked(robot, spell, t)`` (kind ``braked``) or ``overdue(robot, t)`` (kind ``bound``) at ``t``."""

    robot: int
    t: float
    kind: str
    spell: int = 0


@dataclass(frozen=True, slots=True)
class Brake:
    robot: int
    braking: Braking


@dataclass(frozen=True, slots=True)
class DriveOn:
    robot: int
    leg: Leg


@dataclass(frozen=True, slots=True)
class BlockedBy:
    robot: int
    other: int


@dataclass(frozen=True, slots=True)
class Unblocked:
    robot: int


@dataclass(frozen=True, slots=True)
class Deadlocked:
    deadlock: Deadlock


Effect = Predicted | Wake | Brake | DriveOn | BlockedBy | Unblocked | Deadlocked


class Traffic:
    """The fleet's fields, blocks and deadlocks (module docstring). Robots are fleet indices.

    ``footprints``, ``poses`` (at rest at the start), ``fields`` (None: no field) and ``decels`` (m/s^2 the
    robot brakes at; 0: at once) per robot; ``resolution`` as for collisions (m); ``bound``: seconds a
    robot may stay blocked before a ``deadlock`` is reported (None: only cycles are).
    """

    def __init__(self, footprints: Sequence[Footprint], poses: Sequence[Pose], fields: Sequence[Field | None],
                 decels: Sequence[float], resolution: float, bound: float | None = None) -> None:
        self.footprints, self.fields, self.decels = list(footprints), list(fields), list(decels)
        tracks = [Track(i, fp, None, pose, math.inf) for i, (fp, pose) in enumerate(zip(footprints, poses))]
        self.watch = FieldWatch(tracks, resolution)
        self.waits = WaitFor(bound)
        self.legs: dict[int, Leg] = {}  # robot -> the leg it drives (a braked one until it drives on)
        self.brakings: dict[int, Braking] = {}  # blocked robots: how they braked
        self.spells = [0] * len(self.footprints)  # counts each robot's brakes (a Wake names its own)
        self.stopped: set[int] = set()  # blocked robots at rest

    def blocked(self, i: int) -> bool:
        return i in self.brakings

    def drive(self, i: int, leg: Leg, now: float) -> list[Effect]:
        """Robot ``i`` starts ``leg`` at ``now``."""
        effects = self._release(i)
        self.legs[i] = leg
        track = Track(i, self.footprints[i], leg, (leg.x0, leg.y0, leg.theta0), leg.t_end)
        return effects + self._update(i, track, self._driving(i, leg), now)

    def rest(self, i: int, pose: Pose, now: float) -> list[Effect]:
        """Robot ``i`` rests at ``pose`` from ``now`` and does not drive on (it has no field)."""
        effects = self._release(i)
        self.legs.pop(i, None)
        return effects + self._update(i, Track(i, self.footprints[i], None, pose, math.inf), None, now)

    def due(self, change: Change, now: float) -> list[Effect]:
        crossed, follow = self.watch.due(change, now)
        if crossed is None:
            return []
        effects: list[Effect] = [Predicted(c) for c in follow]
        owner, other = crossed.owner, crossed.other
        if not crossed.enters:
            self.waits.unblock(owner, other)
            if crossed.alone:
                effects.append(Unblocked(owner))
                if owner in self.stopped:
                    effects += self._drive_on(owner, now)
            return effects
        if crossed.alone:
            effects.append(BlockedBy(owner, other))
            if owner not in self.brakings:
                effects += self._brake(owner, now)
        found = self.waits.block(owner, other, now)
        if found is not None:
            effects.append(Deadlocked(found))
        if crossed.alone:
            deadline = self.waits.deadline(owner)
            if deadline is not None:
                effects.append(Wake(owner, deadline, BOUND))
        return effects

    def braked(self, i: int, spell: int, now: float) -> list[Effect]:
        """Robot ``i``'s braking number ``spell`` ended at ``now``: drive on if the field is clear, else wait."""
        b = self.brakings.get(i)
        if b is None or spell != self.spells[i]:
            return []
        if not self.watch.holding(i):
            return self._drive_on(i, now)
        self.stopped.add(i)
        field = self.fields[i]
        assert field is not None
        track = Track(i, self.footprints[i], None, b.pose, math.inf)
        effects = self._update(i, track, waiting(i, field, _hold(b), None, b.pose, _goal(b), b.leg.heading), now)
        found = self.waits.stopped(i, now)
        if found is not None:
            effects.append(Deadlocked(found))
        return effects

    def overdue(self, i: int, now: float) -> list[Effect]:
        found = self.waits.overdue(i, now)
        return [] if found is None else [Deadlocked(found)]

    def _brake(self, i: int, now: float) -> list[Effect]:
        b = brake(self.legs[i], now, self.decels[i])
        self.brakings[i] = b
        self.spells[i] += 1
        field = self.fields[i]
        assert field is not None
        start = b.stop.pose_at(now)[:3] if b.stop is not None else b.pose
        until = b.stop.t_end if b.stop is not None else math.inf
        track = Track(i, self.footprints[i], b.stop, start, until)
        # The wake last: changes the brake itself causes at the instant it stops (a robot stopped at once,
        # turned out of another's field) come first, so its stop is judged on fields up to date (no cycle
        # with a robot that is clear at that instant).
        effects: list[Effect] = [Brake(i, b)]
        effects += self._update(i, track, waiting(i, field, _hold(b), b.stop, b.pose, _goal(b), b.leg.heading), now)
        return [*effects, Wake(i, b.t_stop, BRAKED, self.spells[i])]

    def _drive_on(self, i: int, now: float) -> list[Effect]:
        b = self.brakings.pop(i)
        self.stopped.discard(i)
        self.waits.clear(i)
        leg = b.remainder(now)
        self.legs[i] = leg
        track = Track(i, self.footprints[i], leg, b.pose, leg.t_end)
        return [DriveOn(i, leg), *self._update(i, track, self._driving(i, leg), now)]

    def _release(self, i: int) -> list[Effect]:
        """Robot ``i`` is no longer blocked, by an order from outside: its spell ends (``unblocked``). The
        field of what it does next starts empty, so a robot still in it enters it at once and blocks it
        again (else a new leg the same way would drive into it, unblocked)."""
        self.watch.forget(i)
        self.waits.clear(i)
        self.stopped.discard(i)
        if self.brakings.pop(i, None) is None:
            return []
        return [Unblocked(i)]

    def _driving(self, i: int, leg: Leg) -> FieldTrack | None:
        """Robot ``i``'s field driving ``leg``, pointing the way the leg travels; none for a robot without
        one, or for a leg that does not travel (a turn in place only drives into nothing:
        :mod:`vcran.core.traffic.fields`)."""
        field = self.fields[i]
        return driving(i, field, leg) if field is not None and leg.distance > 0 else None

    def _update(self, i: int, track: Track, field: FieldTrack | None, now: float) -> list[Effect]:
        return [Predicted(c) for c in self.watch.update(i, track, field, now)]


def _hold(b: Braking) -> float:
    """The speed a waiting field's length is set for: the speed the robot will drive on at, or the one it
    braked from if higher, so that the waiting field holds whatever the driving field held (no block and
    clear at one instant)."""
    return max(b.speed, b.resume_speed)


def _goal(b: Braking) -> tuple[float, float]:
    """Where the braked motion ends: a waiting field is cut ``margin`` past it, as the driving field was."""
    return b.leg.x1, b.leg.y1
