"""The live edges' end-of-run latency figure (docs/live.md, docs/vda5050.md "Live over MQTT"): one definition for
Orion's and MQTT's, whose p99s were computed two ways (MQTT took the value above the nearest rank)."""

from __future__ import annotations

from transports.base import wall_stats


def test_the_p99_is_the_nearest_rank_and_the_median_the_middle():
    """By hand: 200 values 1 .. 200: 99 % of 200 is 198, so the p99 is the 198th smallest, 198 (the value above,
    199, was MQTT's); the median is the mean of the 100th and 101st, 100.5. 100 values: the 99th, 99."""
    assert wall_stats([float(v) for v in range(200, 0, -1)]) == {"count": 200, "median": 100.5, "p99": 198.0}
    assert wall_stats([float(v) for v in range(1, 101)])["p99"] == 99.0
    assert wall_stats([0.25]) == {"count": 1, "median": 0.25, "p99": 0.25}
    assert wall_stats([]) == {}
