"""Which robot's safety field holds which others, and when that changes next (docs/contract.md §12): pure bookkeeping.

The same predict, schedule, confirm scheme as collision detection (vcran/sim/contacts.py), without SimPy:
the simulation tells :class:`FieldWatch` every change of a robot's track (:meth:`FieldWatch.update`: a leg
starts or ends, a hold, a brake, a stop) and gets back the predicted :class:`Change` instants, which it
schedules; when one is due it hands it back (:meth:`FieldWatch.due`), which confirms it (a prediction made
before a later change of either robot's track is stale: a version check) and says what it means for the
field's robot. A change of a track re-predicts every pair it is part of.

Cost. Each robot is filed in a :class:`~vcran.core.collisions.Grid` under the cells that the box of its
footprint's track and of its field's track touches, and paired only with robots in those cells (and with
those whose field it is in, or that are in its field, wherever they are): cost grows with the fleet, not
its square. A pair is tested exactly (:mod:`vcran.core.traffic.intrusion`, numpy) only when the field's
box and the other's box overlap over the time both tracks hold.

Fields. A robot has a field while it drives (:func:`~vcran.core.traffic.fields.driving`) and while it
is blocked (:func:`~vcran.core.traffic.fields.waiting`); at rest and idle it has none (``field=None``): a
parked robot is not blocked by a robot passing in front of it. A field's set of robots inside persists
across updates (a robot braking, waiting, driving on); a new field that no longer holds one of them predicts
its exit at once. A motion given from outside starts afresh (:meth:`FieldWatch.forget`): whoever is in its
field enters it at once.

What a robot does about it (brake, wait, drive on, report deadlocks) is
:class:`vcran.core.traffic.control.Traffic`'s part, which drives this watch.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from vcran.core.collisions import Box, Grid, Track, apart
from vcran.core.traffic.fields import FieldTrack

#: Grid cell size in metres: a few legs' width.
CELL = 20.0


@dataclass(frozen=True, slots=True)
class Change:
    """At ``t`` robot ``other``'s footprint enters (``enters``) or leaves robot ``owner``'s field.

    ``stamp``: both robots' track versions when predicted (stale once either changes).
    """

    t: float
    owner: int
    other: int
    enters: bool
    stamp: tuple[int, int]


@dataclass(frozen=True, slots=True)
class Crossed:
    """A confirmed change: robot ``other`` entered (``enters``) or left robot ``owner``'s field. ``alone``:
    on entering, the field held nobody before (its robot is blocked now); on leaving, it holds nobody now
    (its robot is clear)."""

    owner: int
    other: int
    enters: bool
    alone: bool


class FieldWatch:
    """The fleet's fields and what is in them (module docstring). Robots are fleet indices."""

    def __init__(self, tracks: Sequence[Track], resolution: float, cell: float = CELL) -> None:
        self.resolution = resolution
        self.grid = Grid(cell)
        self.tracks = list(tracks)
        self.fields: list[FieldTrack | None] = [None] * len(tracks)
        self.boxes: list[Box] = [t.box() for t in tracks]
        self.field_boxes: list[Box | None] = [None] * len(tracks)
        self.version = [0] * len(tracks)
        #: owner -> the robots in its field; other -> the owners whose field it is in
        self.inside: dict[int, set[int]] = {}
        self.within: dict[int, set[int]] = {}
        for i, box in enumerate(self.boxes):
            self.grid.file(i, box)

    def holding(self, owner: int) -> frozenset[int]:
        """The robots in ``owner``'s field now (as far as changes handed to :meth:`due` tell)."""
        return frozenset(self.inside.get(owner, ()))

    def forget(self, owner: int) -> None:
        """``owner``'s field starts afresh (an order from outside replaced its motion): it holds nobody until
        the next :meth:`update` finds them again (a robot still in it enters at once)."""
        for other in self.inside.pop(owner, set()):
            self.within[other].discard(owner)

    def update(self, i: int, track: Track, field: FieldTrack | None, now: float) -> list[Change]:
        """Robot ``i`` goes on along ``track`` with ``field`` (None: none) from ``now``: the changes its
        pairs will see next, in order of (instant, owner, other)."""
        self.version[i] += 1
        self.tracks[i], self.fields[i] = track, field
        self.boxes[i] = box = track.box()
        if field is None:
            self.field_boxes[i] = None
            for other in self.inside.pop(i, set()):
                self.within[other].discard(i)
        else:
            self.field_boxes[i] = fbox = field.box()
            box = (min(box[0], fbox[0]), min(box[1], fbox[1]), max(box[2], fbox[2]), max(box[3], fbox[3]))
        pairs = set(self.grid.file(i, box)) | self.inside.get(i, set()) | self.within.get(i, set())
        changes = []
        for j in sorted(pairs):
            for owner, other in ((i, j), (j, i)):
                change = self._predict(owner, other, now)
                if change is not None:
                    changes.append(change)
        changes.sort(key=lambda c: (c.t, c.owner, c.other))
        return changes

    def due(self, change: Change, now: float) -> tuple[Crossed | None, list[Change]]:
        """``change`` has come: what happened (None: the prediction was stale), and the pair's next change
        (the other robot leaving the field it entered, or entering again the field it left)."""
        owner, other = change.owner, change.other
        if (self.version[owner], self.version[other]) != change.stamp:
            return None, []
        held = self.inside.setdefault(owner, set())
        if change.enters:
            alone = not held
            held.add(other)
            self.within.setdefault(other, set()).add(owner)
        else:
            held.discard(other)
            self.within.get(other, set()).discard(owner)
            alone = not held
        follow = self._predict(owner, other, now)
        return Crossed(owner, other, change.enters, alone), [] if follow is None else [follow]

    def _predict(self, owner: int, other: int, now: float) -> Change | None:
        field = self.fields[owner]
        if field is None:
            return None
        inside = other in self.inside.get(owner, ())
        fbox = self.field_boxes[owner]
        assert fbox is not None
        if not inside and apart(fbox, self.boxes[other]):
            return None  # apart for as long as both tracks hold (the narrower boxes below lie inside these)
        track = self.tracks[other]
        until = min(field.until, track.until)
        if not math.isfinite(until):  # both at rest: nothing changes until one moves
            until = now
        if not inside and apart(field.box(now, until), track.box(now, until)):
            return None
        from vcran.core.traffic.intrusion import first_entry, first_exit  # numpy: only for boxes that meet

        find = first_exit if inside else first_entry
        t = find(field, track, now, until, self.resolution)
        if t is None:
            return None
        return Change(t, owner, other, not inside, (self.version[owner], self.version[other]))
