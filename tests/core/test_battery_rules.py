"""The battery's rules every protocol's body follows (docs/contract.md §4 Battery; vcran/core/battery.py), derived by hand.

A leg of 10 m along +x at 1 m/s with instantaneous acceleration lasts 10 s and has driven t metres at t s."""

from __future__ import annotations

import math

import pytest

from vcran.core.battery import BatteryConfig, charge_refusal, charge_time, empty_stop, leg_cut
from vcran.core.motion import Leg, Limits

LEG = Leg(0.0, 0.0, 0.0, 0.0, 10.0, 0.0, None, Limits(1.0))
BY_THE_METRE = BatteryConfig(capacity=10.0, per_metre=0.1)  # 1 Ah for the whole leg


def test_a_leg_that_costs_less_than_what_is_left_never_empties_the_battery():
    assert leg_cut(BY_THE_METRE, LEG, 2.0, 0.0) == math.inf


def test_a_leg_empties_the_battery_at_the_metre_the_charge_runs_out():
    assert leg_cut(BY_THE_METRE, LEG, 0.5, 0.0) == pytest.approx(5.0)  # 0.5 Ah = 5 m = 5 s
    assert leg_cut(BY_THE_METRE, LEG, 0.3, 2.0) == pytest.approx(3.0)  # from 2 s on: 3 m more


def test_a_charge_ends_when_the_battery_is_full():
    c = BatteryConfig(capacity=10.0, per_idle_second=0.5, charge_rate=2.0)
    assert charge_time(c, 4.0) == pytest.approx(4.0)  # 6 Ah at 2 - 0.5 Ah a second
    assert charge_time(c, 10.0) == 0.0
    assert charge_time(BatteryConfig(capacity=10.0, per_idle_second=0.5, charge_rate=0.5), 4.0) == math.inf


def test_a_charge_is_refused_at_once_without_battery_charger_or_gain_in_that_order():
    assert charge_refusal(False, False, math.inf, 1.0, 2.0)[0] == "action_not_capable"
    assert charge_refusal(True, False, math.inf, 1.0, 2.0) == (
        "no_charger_in_reach", "charge: no charger in reach at 1.000, 2.000")
    assert charge_refusal(True, True, math.inf, 1.0, 2.0)[0] == "charge_too_slow"
    assert charge_refusal(True, True, 4.0, 1.0, 2.0) is None


def test_an_empty_battery_stops_the_robot_until_its_swap_if_any():
    assert empty_stop(BatteryConfig(capacity=1.0, swap_after=30.0), 1.0, 2.5) == (
        "battery empty at 1.000, 2.500: the robot stopped [§4]", 30.0)
    assert empty_stop(BatteryConfig(capacity=1.0), 0.0, 0.0)[1] is None
