"""Task plans: what a fleet manager means to send for one task, and the ways a real one gets it wrong.

A :class:`TaskPlan` names a task, its length and how many of its positions are motions. Its
:meth:`~TaskPlan.assignment` builds the message for one position, either as planned or as one of the
:data:`VARIANTS` that exercise a rule: the same content again with a new ROS header (R10 duplicate), new
content under the same id (R10 replacement, or rejection after dispatch), a wrong length (R2), another id
on a taken position (R2), the wrong kind for the position (R2 kind order, or a different ``m``), a target
outside its motion area (R12). Plans are frozen dataclasses with a plain repr, so a shrunk hypothesis
example that uses them can be pasted into a test as it is printed.
"""

from __future__ import annotations

from dataclasses import dataclass

from vcran.testing._extra import require_hypothesis

require_hypothesis(__name__)

from hypothesis import strategies as st

from vcran.core.opil import build
from vcran.core.opil.messages import Assignment

#: How :meth:`TaskPlan.assignment` may deviate from the plan, and the rule each deviation exercises.
VARIANTS: dict[str, str] = {
    "planned": "the planned assignment",
    "restamped": "R10: the planned content with a new ROS header stamp (a duplicate)",
    "moved": "R10: same id, new content (replaces before dispatch, rejected after)",
    "long": "R2: a sequence length that differs from the task's",
    "intruder": "R2: another id on the same position",
    "other_kind": "R2: an action where a motion is planned, or the reverse",
    "outside": "R12: a motion whose target is outside its own motion area",
    "renumbered": "R10: same id at the next position (moves before dispatch, rejected after)",
}

#: The motion area every "outside" variant carries; planned points never leave it.
AREA = [(-10.0, -10.0), (10.0, -10.0), (10.0, 10.0), (-10.0, 10.0)]
KINDS = ("dummy", "load", "unload")


@dataclass(frozen=True, slots=True)
class TaskPlan:
    """Positions ``1..motions`` are motions, ``motions+1..length`` actions (R2)."""

    task: str
    length: int
    motions: int

    def __post_init__(self) -> None:
        if not 0 <= self.motions <= self.length or self.length < 1:
            raise ValueError(f"a plan needs 0 <= motions <= length and length >= 1, got {self}")

    def is_motion(self, pos: int) -> bool:
        return pos <= self.motions

    def order(self, rotate: int = 0, backwards: bool = False) -> list[int]:
        """Positions 1..length rotated by ``rotate`` and maybe reversed: an arrival order for the task."""
        positions = list(range(1, self.length + 1))
        k = rotate % self.length
        positions = positions[k:] + positions[:k]
        return positions[::-1] if backwards else positions

    def assignment(self, pos: int, variant: str = "planned", stamp: float = 0.0) -> Assignment:
        """The message for position ``pos`` (1-based), as planned or as a :data:`VARIANTS` deviation."""
        if not 1 <= pos <= self.length:
            raise ValueError(f"position {pos} is outside 1..{self.length}")
        if variant not in VARIANTS:
            raise ValueError(f"unknown variant {variant!r}; known: {', '.join(VARIANTS)}")
        motion = self.is_motion(pos) != (variant == "other_kind")
        length = self.length + 1 if variant == "long" else self.length
        name = f"{self.task}_{'m' if motion else 'a'}{pos}" + ("_x" if variant == "intruder" else "")
        if variant == "renumbered":
            pos = pos % self.length + 1
        shift = 1.0 if variant == "moved" else 0.0
        if motion:
            x, y = float(pos) + shift, float(pos % 2)
            if variant == "outside":
                x = 50.0
            return build.motion(self.task, name, pos, length, x, y, area=AREA,
                                stamp=stamp + (1.0 if variant == "restamped" else 0.0))
        kind = KINDS[(pos + (1 if variant == "moved" else 0)) % len(KINDS)]
        return build.action(self.task, name, pos, length, kind)


@st.composite
def task_plans(draw: st.DrawFn, names: tuple[str, ...] = ("A", "B", "C", "D"), max_length: int = 3) -> TaskPlan:
    """Plans for a few task names: reusing names makes plans of one task collide (R2, R9, R10)."""
    length = draw(st.integers(1, max_length))
    return TaskPlan(draw(st.sampled_from(names)), length, draw(st.integers(0, length)))


def variants(planned_weight: int = 6) -> st.SearchStrategy[str]:
    """Mostly the planned assignment, so that tasks complete; every deviation now and then."""
    deviations = [v for v in VARIANTS if v != "planned"]
    return st.sampled_from(["planned"] * planned_weight + deviations)
