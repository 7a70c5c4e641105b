"""A fuzzed variant's determinism, whatever its protocol: run again, byte-identical outputs
(docs/contract.md §5), and its trace replayed without a difference (docs/contract.md §6).

Shared by :func:`vcran.testing.checks.run_variant` (OPIL) and
:func:`vcran.testing.vda5050_runs.run_variant` (VDA 5050), which first run the variant into ``work/a``
and check its own rules.
"""

from __future__ import annotations

from pathlib import Path

from vcran.core.scenario import Scenario
from vcran.io.trace import EVENTS_FILE, LEGS_FILE, SUMMARY_FILE, TRACE_FILE

FILES = (TRACE_FILE, LEGS_FILE, EVENTS_FILE, SUMMARY_FILE)


def again_and_replay(scenario: Scenario, work: Path) -> list[str]:
    """Run ``scenario`` again into ``work/b`` and compare it with ``work/a``; replay ``work/a``'s trace into
    ``work/c`` and verify it. The first difference, or nothing."""
    from transports.replay import ReplayTransport
    from transports.scripted import ScriptedTransport
    from vcran.io.verify import scenario_from_trace, verify
    from vcran.runner import run_to

    run_to(scenario, work / "b", ScriptedTransport(scenario.messages(), frames=False))
    for name in FILES:
        if (work / "a" / name).read_bytes() != (work / "b" / name).read_bytes():
            return [f"{name} differs between two runs of the same scenario (§5)"]
    trace = work / "a" / TRACE_FILE
    run_to(scenario_from_trace(trace), work / "c", ReplayTransport(trace))
    difference = verify(trace, work / "c")
    return [f"replay verification (§6): {difference}"] if difference is not None else []
