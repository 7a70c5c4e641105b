"""A task under assembly: its positions, and the sequence rules R2–R5 as small pure queries.

RanLogic owns the state machine; this module owns "what has been received for a task and what does
that allow". Positions are 1-based. Motions occupy ``1..m`` and actions ``m+1..length`` (R2); ``m`` is
known once R3 holds, which is also the moment the whole path can go to the AGV. What is left of a task
once it ends (R9, R10's re-reads) is :mod:`vcran.core.opil.history`'s.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field, replace

from vcran.core.opil.effects import Reason
from vcran.core.opil.ids import Id
from vcran.core.opil.messages import ActionAssignment, Assignment, CancelTask, MotionAssignment


def same_content(a: Assignment, b: Assignment) -> bool:
    """R10's "identical": equal in everything but the ROS header, whose seq and stamp change on every
    re-send of the same assignment by a fleet manager (a polling re-read is identical anyway)."""
    if isinstance(a, MotionAssignment) and isinstance(b, MotionAssignment):
        return a == replace(b, header=a.header)
    return a == b


def assignment_id(a: Assignment) -> Id:
    return a.motion_id if isinstance(a, MotionAssignment) else a.action_id


def kind_of(a: Assignment) -> str:
    return "motion" if isinstance(a, MotionAssignment) else "action"


def _where(a: Assignment) -> tuple[str, bytes]:
    """``a``'s key in :attr:`Task.where`."""
    return ("motion", a.motion_id.uuid) if isinstance(a, MotionAssignment) else ("action", a.action_id.uuid)


@dataclass(slots=True, eq=False)
class Task:
    """One task id's assignments and progress. Lives in the queue until it ends, then in the history."""

    id: Id
    first_seen: float
    arrival: int
    length: int
    deadline: float
    slots: dict[int, Assignment] = field(default_factory=dict)
    #: (kind, assignment id's uuid) -> position, for duplicate and replacement lookups (R10). Keyed by the
    #: uuid, which is what makes two ids equal, so that a lookup hashes bytes, not an Id through its
    #: Python-level ``__hash__`` (issue 30).
    where: dict[tuple[str, bytes], int] = field(default_factory=dict)
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
        self.where[_where(a)] = pos

    def lookup(self, a: Assignment) -> int | None:
        return self.where.get(_where(a))

    # --- R3, R4, R5 -------------------------------------------------------------------------------------

    def motion_count(self) -> int | None:
        """``m`` when R3 holds (positions 1..m are motions and m == length or m+1 is an action)."""
        if self.m is not None:
            return self.m
        first_action: int | None = None  # one loop, not two generators: this runs for every assignment received
        motions = 0
        for p, a in self.slots.items():
            if isinstance(a, MotionAssignment):
                motions += 1
            elif isinstance(a, ActionAssignment) and (first_action is None or p < first_action):
                first_action = p
        m = self.length if first_action is None else first_action - 1
        return m if motions == m else None

    def actions_complete(self) -> bool:
        """R4, given that R3 holds: every position m+1..length is a received action."""
        m = self.m if self.m is not None else self.motion_count()
        return m is not None and len(self.slots) == self.length

    @property
    def assembled(self) -> bool:
        """R5: every position is received."""
        return len(self.slots) == self.length

    def path(self) -> tuple[MotionAssignment, ...]:
        """The motions to drive: positions 1..m but those cancelled before dispatch (R13)."""
        assert self.m is not None
        path = range(1, self.m + 1)
        if not self.skipped:
            return tuple(map(self.slots.__getitem__, path))  # type: ignore[arg-type]
        return tuple(self.slots[p] for p in path if p not in self.skipped)  # type: ignore[misc]

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
