"""``assignment_status`` reads RanLogic's five ids in one call (issue 14): they must be what the five
properties say, in every state a run reaches (moving, acting, halted, cancelled; SPEC §3, §4)."""

from __future__ import annotations

import pytest

from tests.conftest import ROOT
from transports.scripted import ScriptedTransport
from vcran.core.ids import NIL
from vcran.core.ranlogic import RanLogic
from vcran.io.scenario_file import load
from vcran.runner import run_to


@pytest.mark.parametrize(("name", "acts"), [("demo", True), ("faults", True), ("battery", True), ("crossing", False)])
def test_assignment_ids_are_what_the_properties_say(tmp_path, monkeypatch, name, acts):
    seen = []
    original = RanLogic.assignment_ids

    def checked(self):
        ids = original(self)
        expected = (self.current_task, self.current_motion, self.current_action,
                    self.last_finished_motion, self.last_finished_action)
        assert all(a is b for a, b in zip(ids, expected, strict=True)), (ids, expected)
        seen.append(ids)
        return ids

    monkeypatch.setattr(RanLogic, "assignment_ids", checked)
    scenario = load(ROOT / "scenarios" / f"{name}.toml")
    run_to(scenario, tmp_path / "run", ScriptedTransport(scenario.messages()))
    # the run went through the cases: no task, a leg running, an action running (crossing has no actions)
    assert any(ids[0] is NIL for ids in seen) and any(ids[1] is not NIL for ids in seen)
    assert any(ids[2] is not NIL for ids in seen) == acts
