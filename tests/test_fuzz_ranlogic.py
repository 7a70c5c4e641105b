"""Model-based stateful fuzzing of RanLogic (SPEC §3, R1–R10, R12) against the reference model.

The machine lives in :mod:`vcran.testing.stateful` so that users can run it too; this module runs it
under the active hypothesis profile (tests/conftest.py: ``ci`` by default, ``deep`` for campaigns).
"""

from __future__ import annotations

from vcran.testing.stateful import RanLogicMachine

TestRanLogicAgainstModel = RanLogicMachine.TestCase
