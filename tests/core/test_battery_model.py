"""docs/contract.md §4 Battery, the pure model: the instant a leg drains a battery, derived by hand per phase."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vcran.core.battery import (
    DRIVE,
    REST,
    BatteryConfig,
    FleetBattery,
    leg_empty_after,
    linear_empty_after,
    linear_full_after,
)
from vcran.core.motion import Leg, Limits

# 10 m along +x at 1 m/s, accelerating and braking at 0.5 m/s^2: 2 s (1 m) up, 8 s (8 m) cruising, 2 s down.
TRAPEZOID = Leg(0.0, 0.0, 0.0, 0.0, 10.0, 0.0, None, Limits(1.0, 0.5, 0.5))


def test_s4_battery_empties_while_accelerating():
    # s = 0.25 d^2 while accelerating; 0.1 Ah/m * 0.25 d^2 = 0.05 Ah  ->  d = sqrt(2)
    assert leg_empty_after(TRAPEZOID, 0.05, 0.0, 0.1) == pytest.approx(math.sqrt(2), abs=1e-12)


def test_s4_battery_empties_while_cruising():
    # 0.5 Ah = 5 m: 1 m accelerating (2 s), then 4 m at 1 m/s  ->  t = 6
    assert leg_empty_after(TRAPEZOID, 0.5, 0.0, 0.1) == pytest.approx(6.0, abs=1e-12)


def test_s4_battery_empties_while_braking():
    # 0.95 Ah = 9.5 m; braking from 9 m at t = 10: s = 10 - 0.25 rest^2 = 9.5  ->  rest = sqrt(2), t = 12 - sqrt(2)
    assert leg_empty_after(TRAPEZOID, 0.95, 0.0, 0.1) == pytest.approx(12 - math.sqrt(2), abs=1e-12)


def test_s4_battery_that_outlasts_the_leg_gives_inf():
    assert leg_empty_after(TRAPEZOID, 1.0 + 1e-9, 0.0, 0.1) == math.inf
    assert leg_empty_after(TRAPEZOID, 0.2, 0.0, 0.0) == math.inf


def test_s4_idle_draw_counts_while_turning_and_driving():
    # Facing +x, going to +y: a quarter turn at 1 rad/s first (pi/2 s), drawing only the idle 0.01 Ah/s.
    leg = Leg(0.0, 0.0, 0.0, 0.0, 0.0, 10.0, None, Limits(1.0, 0.0, 0.0, 1.0))
    assert leg_empty_after(leg, 0.01, 0.01, 0.1) == pytest.approx(1.0)
    # After the turn (0.0157 Ah) the draw is 0.01 + 0.1 * 1 m/s = 0.11 Ah/s: 0.2 Ah -> pi/2 + (0.2 - 0.01 pi/2) / 0.11
    assert leg_empty_after(leg, 0.2, 0.01, 0.1) == pytest.approx(math.pi / 2 + (0.2 - 0.01 * math.pi / 2) / 0.11)


def test_s4_linear_segments():
    assert linear_empty_after(0.5, 0.01) == pytest.approx(50.0)
    assert linear_empty_after(0.5, 0.0) == math.inf
    assert linear_empty_after(0.0, 0.01) == 0.0
    assert linear_full_after(0.89, 1.0, 0.01) == pytest.approx(11.0)
    assert linear_full_after(0.5, 1.0, -0.001) == math.inf


def test_s4_fleet_battery_levels_follow_segments_and_clamp():
    b = FleetBattery([BatteryConfig(1.0, initial=0.5, per_metre=0.1, per_idle_second=0.01), None])
    assert list(b.indices) == [0]
    assert b.level(0, 10.0, 0.0) == pytest.approx(0.4)  # resting: 0.01 Ah/s
    assert b.begin(0, 10.0, 0.0, DRIVE) == pytest.approx(0.4)
    assert b.level(0, 12.0, 1.0) == pytest.approx(0.4 - 0.02 - 0.1)  # 2 s and 1 m
    levels, kinds = b.levels(12.0, np.array([1.0, 0.0]))
    assert list(levels) == [pytest.approx(0.28)] and list(kinds) == [DRIVE]
    assert b.level(0, 100.0, 50.0) == 0.0  # never negative
    b.begin(0, 12.0, 1.0, REST)
    assert b.used[0] == pytest.approx(0.1 + 0.12)  # 10 s resting, then 2 s and 1 m driving
