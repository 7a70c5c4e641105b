"""Injected faults (docs/contract.md §4 Faults): what a scenario says goes wrong, and when. Pure data and a seeded stream.

A fault is given at a time (``[[faults]]``) or drawn from a seeded random source (``[[random_faults]]``:
exponential times between failures with mean ``mtbf`` and repair times with mean ``mttr``, per robot).
The SimPy model carries them out (:mod:`vcran.sim.body`, :mod:`vcran.sim.faults`); what each does is in docs/robots.md.
"""

from __future__ import annotations

import math
import random
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

#: Kinds of fault, and whether each takes a duration.
KINDS: dict[str, bool] = {
    "breakdown": True,  # stop mid-leg (or mid-action) for ``duration``, then resume the same task
    "motion_failure": False,  # the running leg ends where the robot is; task cancelled motion_failed
    "action_failure": False,  # the running or next action fails; task cancelled action_failed
    "pause": False,  # stop at once until a ``resume`` (VDA 5050 startPause)
    "resume": False,  # continue after a ``pause`` (VDA 5050 stopPause)
    "trigger": False,  # the trigger a VDA 5050 waitForTrigger waits for is pressed (button, manual loading)
    "link_down": True,  # the robot neither receives nor publishes for ``duration``
}
#: Kinds a random source may draw (pause/resume and trigger are an operator's, not a failure).
RANDOM_KINDS = ("breakdown", "motion_failure", "action_failure", "link_down")
#: The smallest ``mtbf`` and ``mttr`` a random source takes, in seconds: R14's 1 µs, below which two
#: instants are the same to the model. A mean far below it drew faults at one instant forever (``t + gap
#: == t`` once the gaps fall under the float spacing of ``t``): simulated time stopped (docs/robots.md).
MIN_MEAN = 1e-6


@dataclass(frozen=True, slots=True)
class FaultSpec:
    """One fault: at ``t``, ``kind`` happens to ``robot`` (for ``duration`` seconds where it lasts)."""

    t: float
    robot: str
    kind: str
    duration: float = 0.0

    def as_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"t": self.t, "robot": self.robot, "kind": self.kind}
        if KINDS[self.kind]:
            out["duration"] = self.duration
        return out


@dataclass(frozen=True, slots=True)
class RandomFaults:
    """A seeded source of ``kind`` faults for ``robots`` (empty: every robot), from ``start`` to ``until``."""

    kind: str
    mtbf: float
    mttr: float = 0.0
    robots: tuple[str, ...] = ()
    start: float = 0.0
    until: float = math.inf

    def as_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"kind": self.kind, "mtbf": self.mtbf}
        if KINDS[self.kind]:
            out["mttr"] = self.mttr
        if self.robots:
            out["robots"] = list(self.robots)
        if self.start:
            out["start"] = self.start
        if math.isfinite(self.until):
            out["until"] = self.until
        return out

    def stream(self, seed: int, robot: str, n: int = 0) -> Iterator[FaultSpec]:
        """The faults of ``robot``, in time order: a failure ``Exp(mtbf)`` after the previous repair.

        One ``random.Random`` per (scenario seed, kind, robot, ``n``), seeded with a string (hashed with
        SHA-512 by CPython, stable across versions and independent of PYTHONHASHSEED), so adding a robot or a
        source never shifts another robot's faults. ``n`` counts the earlier sources of this kind that
        draw for this robot: a second source of a kind is independent of the first, not its copy (the
        first's string has no ``n``, as before there was one).

        Each failure comes strictly after the previous repair ends, even where a gap is too small to
        change ``t`` in floating point (far out in time): the stream always advances.
        """
        rng = random.Random(f"vcran-faults/{seed}/{self.kind}/{robot}" + (f"/{n}" if n else ""))
        t = self.start
        while True:
            t = max(t + rng.expovariate(1.0 / self.mtbf), math.nextafter(t, math.inf))
            if t >= self.until:
                return
            duration = rng.expovariate(1.0 / self.mttr) if KINDS[self.kind] and self.mttr > 0 else 0.0
            yield FaultSpec(t, robot, self.kind, duration)
            t += duration
