"""R12's area rule on an OPIL motion: its target must lie inside its own motion_area, when it has one.

OPIL's :class:`~vcran.core.opil.messages.MotionAssignment` carries the area; the geometry is the shared
:func:`vcran.core.stations.area_problem`. RanLogic takes the check as a function (``area_check``), so that
its state machine builds no polygon for the nearly every motion that has no area.
"""

from __future__ import annotations

from vcran.core.opil.messages import MotionAssignment
from vcran.core.stations import area_problem


def motion_area_problem(motion: MotionAssignment) -> str | None:
    """R12: why a motion's target lies outside its own non-empty motion_area, or None."""
    if not motion.motion_area.polygon.points:  # no area, as nearly every motion: nothing to build or check
        return None
    points = motion.motion_area.xy()
    return area_problem(points, motion.point.x, motion.point.y) if points else None
