"""``robots.count``: a sweep's short way to vary the number of robots (issue 29 item 11, docs/sweeps.md).

Spelling out the ``[[robots]]`` array for each fleet size is long, and its JSON made an unreadable figure
axis. ``robots.count = N`` sets the fleet to N robots, built from the scenario's own, deterministically:

* N up to the scenario's count keeps its first N robots, in file order.
* Beyond, robot ``i`` (counted from 0) copies robot ``i mod n`` of the scenario's ``n``, every setting
  (speeds, footprint, battery, load) but its id: the copies form whole copies of the fleet's start layout,
  the k-th standing ``k × step`` further along +y, where ``step`` is the layout's extent along y plus a
  gap: the closest two of its robots' spacing (so the layout's density goes on), at least the largest
  footprint's width (twice its farthest corner from the pose, whatever the heading), so no copy overlaps
  another; rounded up to a whole decimetre. The warehouse's rows at y = +-2, 4 m apart, go on at 6 and
  10, then 14 and 18, ...
* A copy's id is ``robot_K``, K counting on from the scenario's count and skipping ids it uses.

The count is applied before every other override of the variant, so ``robots.*.max_velocity`` reaches
the copies too and ``robots.robot_12.pose`` moves one. Whether the result is a scenario (a script or a
fault naming a robot that is gone) is the loader's to say, as for any override.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from typing import Any, NoReturn

from vcran.core.scenario import RobotConfig

PATH = "robots.count"


def set_count(data: dict[str, Any], count: Any, fail: Callable[[str], NoReturn]) -> None:
    """Set ``data``'s ``robots`` to ``count`` robots, in place; ``fail(problem)`` raises for bad input."""
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        fail(f"the number of robots: an integer of at least 1, got {count!r}")
    robots = data.get("robots")
    if not isinstance(robots, list) or not robots or not all(isinstance(r, dict) for r in robots):
        fail("the scenario has no [[robots]] to count from")
    if count <= len(robots):
        data["robots"] = robots[:count]
        return
    step, n = _step(robots), len(robots)
    taken = {r.get("id") for r in robots}
    number = n
    for i in range(n, count):
        template = robots[i % n]
        clone = {k: copy.deepcopy(v) for k, v in template.items() if k not in ("agv_id", "ranlogic_id")}
        x, y, theta = _pose(template)
        clone["pose"] = [x, y + (i // n) * step, theta]
        number += 1
        while f"robot_{number}" in taken:
            number += 1
        clone["id"] = f"robot_{number}"
        taken.add(clone["id"])
        robots.append(clone)


def _pose(robot: dict[str, Any]) -> tuple[float, float, float]:
    x, y, theta = robot.get("pose", RobotConfig.__dataclass_fields__["pose"].default)
    return float(x), float(y), float(theta)


def _step(robots: list[dict[str, Any]]) -> float:
    """How far each copy of the layout stands from the last, along y (the module's docstring)."""
    default = RobotConfig.__dataclass_fields__["footprint"].default
    reach = max((math.hypot(float(px), float(py)) for r in robots for px, py in r.get("footprint", default)),
                default=0.0)
    points = [_pose(r)[:2] for r in robots]
    spacing = min((math.dist(a, b) for i, a in enumerate(points) for b in points[i + 1:]), default=0.0)
    extent = max(y for _, y in points) - min(y for _, y in points)
    return math.ceil(round((extent + max(2 * reach, spacing)) * 10, 6)) / 10
