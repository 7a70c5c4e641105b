"""Fuzzing the VDA 5050 vehicle (docs/contract.md §11, issue 31 item 6): orders, updates, cancels, pauses and
malformed messages in sequences hypothesis chooses, the vehicle's verdicts against the reference model of
its acceptance rules (vcran.testing.vda5050.model), and its invariants after every step."""

from __future__ import annotations

import pytest
from hypothesis import settings

from vcran.testing.vda5050.stateful import VehicleMachine

TestVehicleAgainstModel = pytest.mark.slow(VehicleMachine.TestCase)
TestVehicleAgainstModel.settings = settings(max_examples=60, stateful_step_count=40)
