"""docs/contract.md §12 FieldWatch: predictions are confirmed only while both tracks hold (versions), a field's contents
persist across updates, and the exact test runs only for neighbours (near-linear cost in the fleet)."""

from __future__ import annotations

import math

import pytest

from vcran.core.collisions import Footprint, Track
from vcran.core.motion import Leg, Limits
from vcran.core.traffic import intrusion
from vcran.core.traffic.fields import Field, FieldSpec, driving
from vcran.core.traffic.watch import Crossed, FieldWatch

SQUARE = ((0.5, 0.5), (-0.5, 0.5), (-0.5, -0.5), (0.5, -0.5))
LIMITS = Limits(1.0, 0.5, 0.5)
FIELD = Field.of(FieldSpec(margin=2.0), SQUARE, 0.5)
FOOT = Footprint(SQUARE)


def rest(i: int, x: float, y: float = 0.0) -> Track:
    return Track(i, FOOT, None, (x, y, 0.0), math.inf)


def test_a_prediction_is_confirmed_only_while_both_tracks_hold() -> None:
    # robot 1 rests at (15, 0); robot 0 drives east from the origin: its field meets robot 1 at t = 12
    # (test_traffic_control derives it)
    watch = FieldWatch([rest(0, 0.0), rest(1, 15.0)], 0.05)
    leg = Leg(0.0, 0.0, 0.0, 0.0, 20.0, 0.0, None, LIMITS)
    [change] = watch.update(0, Track(0, FOOT, leg, (0.0, 0.0, 0.0), leg.t_end), driving(0, FIELD, leg), 0.0)
    assert (change.owner, change.other, change.enters) == (0, 1, True) and change.t == pytest.approx(12.0, abs=1e-6)
    # robot 1 moves away before: the prediction is stale, and the update predicted anew (nothing: it runs off)
    away = Leg(5.0, 15.0, 0.0, 0.0, 100.0, 0.0, None, Limits(5.0, 5.0, 5.0))
    assert watch.update(1, Track(1, FOOT, away, (15.0, 0.0, 0.0), away.t_end), None, 5.0) == []
    assert watch.due(change, change.t) == (None, [])
    assert watch.holding(0) == frozenset()


def test_entering_and_leaving_are_confirmed_with_the_pair_next_change() -> None:
    watch = FieldWatch([rest(0, 0.0), rest(1, 15.0)], 0.05)
    leg = Leg(0.0, 0.0, 0.0, 0.0, 20.0, 0.0, None, LIMITS)
    [change] = watch.update(0, Track(0, FOOT, leg, (0.0, 0.0, 0.0), leg.t_end), driving(0, FIELD, leg), 0.0)
    crossed, follow = watch.due(change, change.t)
    assert crossed == Crossed(0, 1, True, True) and watch.holding(0) == {1}
    # robot 0 does not brake here: it drives through robot 1, whose front side (15.5) falls behind the field's
    # back (robot 0's front, x + 0.5) when robot 0 is at 15: t = 2 + 14 = 16
    [leaves] = follow
    assert (leaves.enters, leaves.t) == (False, pytest.approx(16.0, abs=1e-6))
    # robot 0 stops where it is without a field: it holds nobody any more
    pose = leg.pose_at(change.t)[:3]
    assert watch.update(0, Track(0, FOOT, None, pose, math.inf), None, change.t) == []
    assert watch.holding(0) == frozenset()


def test_only_neighbours_are_tested_exactly(monkeypatch: pytest.MonkeyPatch) -> None:
    """Near-linear cost: 300 robots 50 m apart, each driving 20 m east with its field: a robot's update
    pairs it only with the robots in its grid cells (20 m), so no pair is even looked at, let alone tested
    exactly."""
    calls, pairs = [], []
    real, predict = intrusion.first_entry, FieldWatch._predict

    def counting(*args: object) -> object:
        calls.append(args)
        return real(*args)  # type: ignore[arg-type]

    def looking(self: FieldWatch, owner: int, other: int, now: float) -> object:
        pairs.append((owner, other))
        return predict(self, owner, other, now)

    monkeypatch.setattr(intrusion, "first_entry", counting)
    monkeypatch.setattr(FieldWatch, "_predict", looking)
    n = 300
    watch = FieldWatch([rest(i, 50.0 * i) for i in range(n)], 0.05)
    for i in range(n):
        leg = Leg(0.0, 50.0 * i, 0.0, 0.0, 50.0 * i + 20.0, 0.0, None, LIMITS)
        assert watch.update(i, Track(i, FOOT, leg, leg.pose_at(0.0)[:3], leg.t_end), driving(i, FIELD, leg), 0.0) == []
    assert calls == [] and pairs == []
    # a robot parked 2 m past robot 7's goal is met by robot 7's field, and tested against it alone
    watch.update(n - 1, rest(n - 1, 50.0 * 7 + 23.0), None, 0.0)
    assert len(calls) == 1 and calls[0][0].index == 7
