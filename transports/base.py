"""The transport interface (defined in :mod:`vcran.core.wire`, so the simulation needs only the core)."""

import math
import statistics
from collections.abc import Collection

from vcran.core.wire import Deliver, Transport

__all__ = ["Deliver", "Transport", "wall_stats"]


def wall_stats(seconds: Collection[float]) -> dict[str, float]:
    """A live edge's end-of-run figure over wall-clock durations: ``count``, ``median`` and ``p99`` (nearest
    rank: the smallest value with at least 99 % of them at or below it); empty without any. One definition for
    every edge, so that their printed p99s mean the same (vcran.commands.live.latency_line)."""
    if not seconds:
        return {}
    ordered = sorted(seconds)
    return {"count": len(ordered), "median": statistics.median(ordered),
            "p99": ordered[max(0, math.ceil(0.99 * len(ordered)) - 1)]}
