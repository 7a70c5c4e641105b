"""Braking to a stop from any instant of a leg, and driving on from rest (docs/contract.md §12 safety fields).

A robot whose field is entered brakes at its deceleration ``d`` from the speed ``v`` it has at that
instant, straight on along its leg: it stops ``v^2 / (2 d)`` further on, ``v / d`` later. A robot turning
in place (speed 0) stops turning at once (turns have no angular ramps in vcran: docs/contract.md §4). A robot whose
deceleration is not limited (0, "instantaneous", as :class:`vcran.core.motion.Limits` says) stops where it
is. It never stops beyond its leg's end: a leg that brakes harder than ``d`` at its end (its own
deceleration unlimited) is cut there.

The braked stretch is itself a :class:`~vcran.core.motion.Leg`, so nothing new is needed to hold it: a leg
whose acceleration is unlimited starts at its top speed (``Limits(speed=v, accel=0, decel=d)``), and from
the point where the robot is to the point where it stops that leg *is* the braking profile (its ramps
cover exactly its length: no cruise). :class:`vcran.core.motion.FleetKinematics`, the sampling sweeps,
collision tracks and the leg log take it as they take any leg. Driving on is a new leg from rest at the
stopping pose to the braked leg's goal (:meth:`Braking.remainder`): the rest of the motion, with its
limits, its turn first (none when the robot stopped on its line) and its final heading.

How the SimPy body uses it (issue 32's integration): at the instant the field is entered,
``b = brake(leg, now, decel)``; ``fleet.stop(i, now)`` ends the running leg there (its distance is banked)
and, when ``b.stop`` is not None, ``fleet.start(i, b.stop)`` drives the braked stretch, ``fleet.finish(i)``
at ``b.t_stop``. When the field is clear (at or after ``b.t_stop``), ``fleet.start(i, b.remainder(t))``.
"""

from __future__ import annotations

from dataclasses import dataclass

from vcran.core.motion import Leg, Limits


@dataclass(frozen=True, slots=True)
class Braking:
    """``leg`` braked from ``t``: the braked stretch ``stop`` (None: stopped at once), ending at ``t_stop``
    with the robot at rest at ``pose``."""

    leg: Leg
    t: float
    stop: Leg | None
    t_stop: float
    pose: tuple[float, float, float]

    def remainder(self, t: float) -> Leg:
        """The rest of the braked leg, driven from rest at :attr:`pose` from ``t`` (at or after ``t_stop``)."""
        x, y, theta = self.pose
        leg = self.leg
        return Leg(t, x, y, theta, leg.x1, leg.y1, leg.theta_goal, leg.limits)

    @property
    def speed(self) -> float:
        """The speed the robot had when it began to brake."""
        return self.stop.limits.speed if self.stop is not None else 0.0

    @property
    def resume_speed(self) -> float:
        """The top speed of :meth:`remainder`: what a waiting field's length is set for (vcran.core.traffic.fields)."""
        return self.remainder(self.t_stop).peak


def brake(leg: Leg, t: float, decel: float) -> Braking:
    """Brake ``leg`` from ``t`` at ``decel`` m/s^2 (0: at once) to a stop (module docstring)."""
    x, y, theta, v, _ = leg.pose_at(t)
    if v <= 0.0 or decel <= 0.0:
        return Braking(leg, t, None, t, (x, y, theta))
    s_end = min(leg.distance_at(t) + 0.5 * v * v / decel, leg.distance)
    if s_end >= leg.distance:
        x1, y1 = leg.x1, leg.y1
    else:
        x1, y1 = leg.x0 + leg.ux * s_end, leg.y0 + leg.uy * s_end
    if x1 == x and y1 == y:  # a stretch too short to represent: stopped
        return Braking(leg, t, None, t, (x, y, theta))
    # No turn: the stretch's own heading differs from the leg's in the last bits at most, and a turn rate of 0
    # makes that a turn of no time.
    stop = Leg(t, x, y, theta, x1, y1, None, Limits(v, 0.0, decel, 0.0))
    return Braking(leg, t, stop, stop.t_end, (stop.x1, stop.y1, stop.end_theta))
