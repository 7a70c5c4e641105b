"""A task under assembly: its positions, and the sequence rules R2–R5 as small pure queries.

RanLogic owns the state machine; this module owns "what has been received for a task and what does
that allow". Positions are 1-based. Motions occupy ``1..m`` and actions ``m+1..length`` (R2); ``m`` is
known once R3 holds, which is also the moment the whole path can go to the AGV.
"""

from __future__ import annotations

import pickle
import struct
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from hashlib import blake2b
from typing import Any

from vcran.core.effects import Reason
from vcran.core.ids import Id
from vcran.core.messages import ActionAssignment, Assignment, CancelTask, MotionAssignment
from vcran.core.schema import specs


def same_content(a: Assignment, b: Assignment) -> bool:
    """R10's "identical": equal in everything but the ROS header, whose seq and stamp change on every
    re-send of the same assignment by a fleet manager (a polling re-read is identical anyway)."""
    if isinstance(a, MotionAssignment) and isinstance(b, MotionAssignment):
        return a == replace(b, header=a.header)
    return a == b


_FLATTENERS: dict[type, Callable[[Any], tuple[Any, ...]]] = {}
#: Float fields are flattened as ``v + 0.0``, which turns -0.0 into 0.0: R10 compares numbers (-0.0 == 0.0),
#: so the fingerprint must not tell the signs of a zero apart (pickle would).
_FLOATS = ("float64", "float32")


def _flattener(cls: type, skip: str = "") -> Callable[[Any], tuple[Any, ...]]:
    """A function returning every primitive of a ``cls`` in schema order, ids by their uuid only
    (SPEC §2), zeros unsigned, without the field ``skip``. Generated once per class from :func:`specs`: a generic walk
    costs several times more, and this runs for every assignment of every ended task."""
    key = (cls, skip)
    found = _FLATTENERS.get(key)  # type: ignore[call-overload]
    if found is not None:
        return found
    helpers: dict[str, Any] = {}
    parts: list[str] = []

    def walk(c: type, path: str, omit: str = "") -> None:
        for spec in specs(c):
            if spec.name == omit:
                continue
            here = f"{path}.{spec.name}"
            if spec.kind == "prim":
                parts.append(f"({here} + 0.0)" if spec.ros in _FLOATS else here)
            elif spec.kind == "id":
                parts.append(f"{here}.uuid")
            elif spec.kind == "msg":
                walk(spec.cls, here)  # type: ignore[arg-type]
            else:
                name = f"_a{len(helpers)}"
                if spec.cls is None and spec.ros[:-2] in _FLOATS:
                    helpers[name] = lambda items: (len(items), *(v + 0.0 for v in items))
                elif spec.cls is None:
                    helpers[name] = lambda items: (len(items), *items)
                elif spec.cls is Id:
                    helpers[name] = lambda items: (len(items), *(i.uuid for i in items))
                else:
                    inner = _flattener(spec.cls)
                    helpers[name] = lambda items, inner=inner: (len(items), *(v for i in items for v in inner(i)))
                parts.append(f"*{name}({here})")

    walk(cls, "m", skip)
    found = eval(f"lambda m: ({', '.join(parts)},)", helpers)  # noqa: S307 - source built from specs only
    _FLATTENERS[key] = found  # type: ignore[index]
    return found


def fingerprint(a: Assignment | CancelTask) -> bytes:
    """A 16-byte digest of what :func:`same_content` compares: the kind and every field but the header.

    Ended tasks keep these instead of their assignments, so the R9 history costs tens of bytes per
    assignment, not a kilobyte. Deterministic (no salted ``hash()``): the schema-ordered primitives are
    pickled (floats and bytes pickle exactly) and hashed with blake2b. Two assignments that differ
    collide with probability 2**-128, and even then only a re-read that should have been reported (R9)
    would go silent: an ended task applies nothing either way.
    """
    content = (type(a).__name__, *_flattener(type(a), "header")(a))  # only MotionAssignment has one
    return blake2b(pickle.dumps(content, protocol=5), digest_size=16).digest()


def assignment_id(a: Assignment) -> Id:
    return a.motion_id if isinstance(a, MotionAssignment) else a.action_id


def kind_of(a: Assignment) -> str:
    return "motion" if isinstance(a, MotionAssignment) else "action"


@dataclass(slots=True, eq=False)
class Task:
    """One task id's assignments and progress. Lives in the queue until it ends, then in the history."""

    id: Id
    first_seen: float
    arrival: int
    length: int
    deadline: float
    slots: dict[int, Assignment] = field(default_factory=dict)
    #: (kind, assignment id) -> position, for duplicate and replacement lookups (R10).
    where: dict[tuple[str, Id], int] = field(default_factory=dict)
    #: Number of motions, fixed when the path is dispatched (R3); None before.
    m: int | None = None
    #: Positions of the dispatched path still to drive, the running leg first (R13 may drop later ones).
    route: deque[int] = field(default_factory=deque)
    #: Position of the next action to dispatch, and whether one is running.
    next_action: int = 0
    action_running: bool = False
    #: Positions cancelled one by one (R13): received for R3-R5, never performed.
    skipped: set[int] = field(default_factory=set)
    #: When the running leg or action began (R14: a cancel or timeout at that instant abandons it).
    since: float = float("-inf")
    #: Why the task is ending while its running leg or action finishes (R8), if it is.
    ending: Reason | None = None
    #: The cancel that is ending it, kept for the history so that its re-reads stay silent (R10).
    cancel: CancelTask | None = None

    # --- R2 ---------------------------------------------------------------------------------------------

    def position_problem(self, a: Assignment, replacing: int | None) -> tuple[str, str] | None:
        """Why ``a`` cannot take its position (code, message), or None. ``replacing`` is ignored (R10)."""
        pos, length = a.sequence.sequence_number, a.sequence.length
        if length != self.length:
            return "length_mismatch", f"sequence length {length} differs from the task's length {self.length} [R2]"
        other = self.slots.get(pos)
        if other is not None and pos != replacing:
            return "position_taken", (
                f"position {pos} already holds {kind_of(other)} {assignment_id(other).label} [R2]"
            )
        for p, b in self.slots.items():
            if p == replacing:
                continue
            if isinstance(a, MotionAssignment) and isinstance(b, ActionAssignment) and p < pos:
                return "kind_order", f"motion at position {pos} after action at position {p} [R2]"
            if isinstance(a, ActionAssignment) and isinstance(b, MotionAssignment) and p > pos:
                return "kind_order", f"action at position {pos} before motion at position {p} [R2]"
        return None

    def put(self, a: Assignment, replacing: int | None) -> None:
        if replacing is not None:
            del self.slots[replacing]
        pos = a.sequence.sequence_number
        self.slots[pos] = a
        self.where[(kind_of(a), assignment_id(a))] = pos

    def lookup(self, a: Assignment) -> int | None:
        return self.where.get((kind_of(a), assignment_id(a)))

    # --- R3, R4, R5 -------------------------------------------------------------------------------------

    def motion_count(self) -> int | None:
        """``m`` when R3 holds (positions 1..m are motions and m == length or m+1 is an action)."""
        if self.m is not None:
            return self.m
        first_action = min((p for p, a in self.slots.items() if isinstance(a, ActionAssignment)), default=None)
        motions = sum(1 for a in self.slots.values() if isinstance(a, MotionAssignment))
        m = self.length if first_action is None else first_action - 1
        return m if motions == m else None

    def actions_complete(self) -> bool:
        """R4, given that R3 holds: every position m+1..length is a received action."""
        m = self.motion_count()
        return m is not None and len(self.slots) == self.length

    @property
    def assembled(self) -> bool:
        """R5: every position is received."""
        return len(self.slots) == self.length

    def path(self) -> tuple[MotionAssignment, ...]:
        """The motions to drive: positions 1..m but those cancelled before dispatch (R13)."""
        assert self.m is not None
        return tuple(self.slots[p] for p in range(1, self.m + 1) if p not in self.skipped)  # type: ignore[misc]

    def skip_cancelled_actions(self) -> None:
        """Move ``next_action`` past actions cancelled before their turn (R13)."""
        while self.next_action in self.skipped:
            self.next_action += 1

    def refusal(self, pos: int) -> tuple[str, str] | None:
        """R13: why the assignment at ``pos`` can no longer be cancelled on its own (code, message), or None."""
        a = self.slots[pos]
        what = f"{kind_of(a)} {assignment_id(a).label}"
        if self.m is not None and pos <= self.m:  # a motion of the dispatched path
            if pos not in self.route:
                return "assignment_finished", f"{what} was already reached [R13]"
            if pos == self.route[0]:
                return "assignment_running", f"{what} is the running leg [R13]"
        elif self.m is not None and pos < self.next_action:
            return "assignment_finished", f"{what} was already performed [R13]"
        elif self.action_running and pos == self.next_action:
            return "assignment_running", f"{what} is the running action [R13]"
        return None

    def action_at(self, pos: int) -> ActionAssignment:
        a = self.slots[pos]
        assert isinstance(a, ActionAssignment)
        return a

    def dispatched(self, pos: int) -> bool:
        """Whether the assignment at ``pos`` has gone to the AGV or AgvAction (R10 replacement limit);
        ``pos`` is not a cancelled one (R13)."""
        if self.m is None:
            return False
        if pos <= self.m:
            return True
        return pos < self.next_action or (pos == self.next_action and self.action_running)


_REASONS: tuple[Reason | None, ...] = (None, *Reason)
_FIXED = struct.Struct("<dB16s")  # end time, reason (0: completed), fingerprint of the last cancel or zeros
_NO_CANCEL = bytes(16)
#: What one history entry costs besides its record (key bytes object, dict slot, eviction queue slot):
#: the unit of the memory bound, with the record's own length.
ENTRY_OVERHEAD = 120


@dataclass(slots=True, eq=False)
class Ended:
    """A finished task in the history (R9), or a tombstone left by a cancel for an unknown id (R8).

    It keeps only what R9 and R10 still ask of an ended task: the fingerprints of its assignments, so
    that a re-read of one of them stays silent, and the fingerprint of its last cancel. In the
    :class:`History` it lives as one ``bytes`` record (fixed 25 bytes plus 16 per assignment), decoded
    back into this view only when an id of an ended task is seen again.
    """

    received: frozenset[bytes]
    reason: Reason | None  # None: completed
    time: float
    #: Fingerprint of the last cancel received for this id, so that re-reads of it stay silent (R10).
    cancel: bytes = _NO_CANCEL

    @classmethod
    def of(cls, task: Task | None, reason: Reason | None, time: float, cancel: CancelTask | None = None) -> Ended:
        received = frozenset(map(fingerprint, task.slots.values())) if task is not None else frozenset()
        return cls(received, reason, time, fingerprint(cancel) if cancel is not None else _NO_CANCEL)

    def has_identical(self, a: Assignment) -> bool:
        """R10: ``a`` is a re-read of one of the task's assignments."""
        return bool(self.received) and fingerprint(a) in self.received

    def same_cancel(self, cancel: CancelTask) -> bool:
        return self.cancel == fingerprint(cancel)

    def record(self) -> bytes:
        return _FIXED.pack(self.time, _REASONS.index(self.reason), self.cancel) + b"".join(sorted(self.received))

    @classmethod
    def from_record(cls, record: bytes) -> Ended:
        time, reason, cancel = _FIXED.unpack_from(record)
        rest = memoryview(record)[_FIXED.size:]
        received = frozenset(bytes(rest[i:i + 16]) for i in range(0, len(rest), 16))
        return cls(received, _REASONS[reason], time, cancel)


class History:
    """R9: the ended task ids of one robot, oldest first, bounded by count and by memory.

    One ``bytes`` record per ended task keyed by the task's uuid bytes (an id is its uuid, SPEC §2), so a
    long run's memory grows by about 0.2 kB per ended task until the bound, not by the task's messages.
    ``limit`` is R9's count (``history_limit``); ``max_bytes`` bounds the records plus
    :data:`ENTRY_OVERHEAD` each, so that tasks with very many assignments cannot grow it without end.
    """

    __slots__ = ("limit", "max_bytes", "_records", "_order", "_bytes")

    def __init__(self, limit: int, max_bytes: int) -> None:
        self.limit, self.max_bytes = limit, max_bytes
        self._records: dict[bytes, bytes] = {}
        self._order: deque[bytes] = deque()
        self._bytes = 0

    def __len__(self) -> int:
        return len(self._records)

    def __iter__(self) -> Iterator[Id]:
        """The remembered task ids, oldest first (as ids without description: only the uuid is kept)."""
        return (Id(key) for key in self._order)

    def get(self, task_id: Id) -> Ended | None:
        record = self._records.get(task_id.uuid)
        return Ended.from_record(record) if record is not None else None

    def remember(self, task_id: Id, ended: Ended) -> None:
        key = task_id.uuid
        old = self._records.pop(key, None)
        if old is not None:  # not the case in RanLogic (an id in the history never re-enters it), kept exact anyway
            self._order.remove(key)
            self._bytes -= len(old) + ENTRY_OVERHEAD
        record = ended.record()
        self._records[key] = record
        self._order.append(key)
        self._bytes += len(record) + ENTRY_OVERHEAD
        while len(self._records) > self.limit or (self._bytes > self.max_bytes and len(self._records) > 1):
            oldest = self._order.popleft()
            self._bytes -= len(self._records.pop(oldest)) + ENTRY_OVERHEAD

    def replace(self, task_id: Id, ended: Ended) -> None:
        """Update an entry in place (a later cancel of an ended task), keeping its age."""
        old = self._records[task_id.uuid]
        record = ended.record()
        self._records[task_id.uuid] = record
        self._bytes += len(record) - len(old)
