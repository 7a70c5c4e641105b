"""Collision detection in the simulation (docs/contract.md §4 Footprints and collisions): predict, schedule, confirm.

Whenever a robot's track changes (a leg starts or ends, a hold, a stop: :attr:`Body.on_move`), it is
re-filed in the :class:`~vcran.core.collisions.Grid` and tested against the robots sharing a cell: for
each such pair the first instant their footprints start to touch (or, for a pair already in contact, stop
touching) before either track ends is computed (:func:`~vcran.core.overlap.first_change`) and an event
is scheduled then. Any later change of either robot's track makes that prediction stale (a version check),
and the change itself predicts anew. A contact is reported once, as one ``collision`` event (on the robot
first in fleet order, naming the other). In ``"report"`` mode that is all: the robots drive on and
publish exactly what they would without detection (the original drove through silently, so the wire
and a fleet manager's view stay the original's); in ``"stop"`` mode both robots stop where they are, and
their protocols' logics are told (OPIL's RanLogic reports ``collision`` and cancels their tasks with reason
``collision``).
"""

from __future__ import annotations

import math

import simpy

from vcran.core.collisions import Box, Footprint, Grid, Track, apart
from vcran.core.incidents import Collision
from vcran.sim.body import Body
from vcran.sim.holds import COLLISION, Halted
from vcran.sim.timing import COMPLETION, at

#: Grid cell size in metres: a few legs' width, so a leg's box touches a handful of cells. 30 m is half of
#: ``vcran gen``'s 60 m cell per robot, whose work area (footprint included: within 26 m of its home across, from
#: 1 m below to 23 m above it) then lies in cells of its own: a generated fleet's robots are never each other's
#: neighbours, and a robot stays filed where it is after its first two legs. With 20 m cells, neighbours shared a
#: column and every other leg moved a robot to other cells: the grid was 5% of a generated 200-robot quarter
#: hour's instructions (callgrind), 2.5% now; the bundled warehouse's collisions are the same to the instant, and
#: its run is no slower (issue 30).
CELL = 30.0


class Contacts:
    def __init__(self, env: simpy.Environment, robots: list[Body], mode: str, resolution: float) -> None:
        self.env, self.robots, self.stop, self.resolution = env, robots, mode == "stop", resolution
        self.grid = Grid(CELL)
        self.footprints = [Footprint(r.config.footprint) for r in robots]
        self.tracks: list[Track] = []
        #: Each track's box (:meth:`Track.box`), made once: the grid files it and pair tests start from it.
        self.boxes: list[Box] = []
        self.version = [0] * len(robots)
        self.touching: set[tuple[int, int]] = set()
        self.count = [0] * len(robots)
        for r in robots:
            self.tracks.append(self._track(r))
            self.boxes.append(self.tracks[-1].box())
        for r in robots:
            r.on_move = self.moved
            self._check(r.index)

    def _track(self, robot: Body) -> Track:
        leg = robot.fleet.current.get(robot.index)
        until = leg.t_end if leg is not None else math.inf
        return Track(robot.index, self.footprints[robot.index], leg, robot.pose, until)

    def moved(self, robot: Body) -> None:
        i = robot.index
        self.version[i] += 1
        track = self.tracks[i] = self._track(robot)
        self.boxes[i] = box = track.box()
        for j in self.grid.file(i, box):  # _check(i), written out: three moves a task (issue 30)
            self._predict(min(i, j), max(i, j))

    def _check(self, i: int) -> None:
        for j in self.grid.file(i, self.boxes[i]):
            self._predict(min(i, j), max(i, j))

    def _predict(self, i: int, j: int) -> None:
        pair = (i, j)
        in_contact = pair in self.touching
        if not in_contact and apart(self.boxes[i], self.boxes[j]):
            # Apart for as long as both tracks hold (most neighbours the grid gives): the narrower boxes below
            # lie inside these (BOX_PAD covers rounding), so no pair that could touch is dropped here, and
            # the two Leg.pose_at calls they cost are saved.
            return
        a, b = self.tracks[i], self.tracks[j]
        now = self.env.now
        until = min(a.until, b.until)
        if not math.isfinite(until):  # both at rest: the situation cannot change until one moves
            until = now
        # What each covers until either changes: pairs whose boxes are apart cannot start touching then.
        ta, tb = a.box(now, until), b.box(now, until)
        if not in_contact and apart(ta, tb):
            return
        # A contact's end is reported nowhere: it only says from when the pair can collide again, so the
        # first sample apart does (a re-contact within that step would be a graze below the resolution).
        from vcran.core.overlap import first_change  # the exact test: only for pairs whose boxes overlap

        t = first_change(a, b, now, until, self.resolution, want=not in_contact, exact=not in_contact)
        if t is None:
            return
        stamp = (self.version[i], self.version[j])
        event = at(self.env, t, COMPLETION)
        event.callbacks.append(lambda _: self._due(i, j, stamp, not in_contact))

    def _due(self, i: int, j: int, stamp: tuple[int, int], starts: bool) -> None:
        if (self.version[i], self.version[j]) != stamp:
            return  # a track changed since: the change predicted anew
        pair = (i, j)
        if not starts:
            self.touching.discard(pair)
            self._predict(i, j)
            return
        self.touching.add(pair)
        a, b = self.tracks[i], self.tracks[j]
        from vcran.core.overlap import contact_point

        x, y = contact_point(a, b, self.env.now)
        ra, rb = self.robots[i], self.robots[j]
        self.count[i] += 1
        self.count[j] += 1
        ra.log_incident(Collision(rb.id, x, y))
        where = f"at {x:.3f}, {y:.3f}"
        if self.stop:
            for robot, other in ((ra, rb), (rb, ra)):
                robot.halt(Halted(COLLISION, f"collided with {other.id} {where}: stopped [§4]"))
        else:
            self._predict(i, j)  # when they part again
