"""A VDA 5050 scenario's fuzz variants as scenario files and runs (``vcran fuzz``, docs/fuzzing.md "VDA 5050
scenarios"): the part of :mod:`vcran.testing.vda5050`'s fuzzing that goes through the shared files and runner,
which import OPIL's modules (the scenario reader builds OPIL's script messages) and so may not be imported
from that package (the import contract "VDA 5050 imports nothing of OPIL's").
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from vcran.core.scenario import Scenario
from vcran.io.scenario_toml import dumps, scenario_dict
from vcran.io.trace import EVENTS_FILE, event_records, trace_records
from vcran.testing.vda5050.checks import check_run
from vcran.testing.vda5050.fuzz import Perturbation, Table, apply
from vcran.testing.vda5050.fuzz import perturbations as _perturbations

if TYPE_CHECKING:
    from hypothesis.strategies import SearchStrategy


def script_tables(base: Scenario) -> list[Table]:
    """``base``'s script as the ``[[script]]`` tables its file would hold (messages without headers)."""
    return list(scenario_dict(base, list(base.messages()))["script"])


def perturbations(base: Scenario, *, window: int = 3, max_ops: int = 8) -> SearchStrategy[list[Perturbation]]:
    """:func:`vcran.testing.vda5050.fuzz.perturbations` of ``base``'s script."""
    return _perturbations(base, script_tables(base), window=window, max_ops=max_ops)


def perturbed_toml(base: Scenario, ops: Sequence[Perturbation], header: str = "") -> str:
    """``base`` with its script perturbed by ``ops``, as a scenario file. A message delayed or repeated
    past the run's end never arrives (a scenario file may not send it then)."""
    end = base.settings.duration
    data = base.fleet_dict()
    data["script"] = [t for t in apply(script_tables(base), ops) if end is None or t["t"] <= end]
    return dumps(data, header)


def run_variant(scenario: Scenario, work: Path, *, again: bool = True) -> list[str]:
    """Run ``scenario`` into ``work/a`` and return every violation of VDA 5050's properties
    (:mod:`vcran.testing.vda5050.checks`); with ``again``, run it a second time (byte-identical outputs,
    docs/contract.md §5) and replay its trace (docs/contract.md §6). A crash is a violation."""
    from transports.scripted import ScriptedTransport
    from vcran.runner import run_to
    from vcran.testing.variant import again_and_replay

    try:
        result = run_to(scenario, work / "a", ScriptedTransport(scenario.messages(), frames=False))
        records, events = trace_records(work / "a"), list(event_records(work / "a" / EVENTS_FILE))
        problems = check_run(records, events, scenario, finished=result.model.protocol.idle())
        if problems or not again:
            return problems
        return again_and_replay(scenario, work)
    except Exception as exc:  # noqa: BLE001 - any crash on input is the finding
        return [f"crash: {type(exc).__name__}: {exc}"]
