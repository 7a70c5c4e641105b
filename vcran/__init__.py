"""vcran: a headless, deterministic re-implementation of the OPIL VC-RAN (see README.md).

This module is the public API: what users import, re-exported from the layers that define it
(``vcran.core`` pure, ``vcran.sim`` SimPy, ``vcran.io`` files; README "Layout"). Everything else is
internal and may move. ::

    import vcran

    scenario = vcran.load_scenario("scenarios/demo.toml")
    print([robot.id for robot in scenario.robots])
    result = vcran.simulate("scenarios/warehouse.toml")   # in memory; docs/library.md
    print(result.summary["jobs"]["completed"])

The names are loaded on first use (PEP 562), not at ``import vcran``: every ``import vcran.core.x``
runs this file first, and the pure core must stay free of SimPy and httpx (an import contract and a
test check it), while ``vcran --help`` should not pay for numpy and SimPy.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

#: Public name -> (module, attribute). The one list of what ``vcran`` exports.
_EXPORTS: dict[str, tuple[str, str]] = {
    # scenarios: the data model and its files
    "Scenario": ("vcran.core.scenario", "Scenario"),
    "Settings": ("vcran.core.scenario", "Settings"),
    "RobotConfig": ("vcran.core.scenario", "RobotConfig"),
    "StationConfig": ("vcran.core.scenario", "StationConfig"),
    "ScriptEntry": ("vcran.core.scenario", "ScriptEntry"),
    "Script": ("vcran.core.scenario", "Script"),
    "load_scenario": ("vcran.io.scenario_file", "load"),
    "parse_scenario": ("vcran.io.scenario_file", "parse"),
    "ScenarioError": ("vcran.io.scenario_file", "ScenarioError"),
    # messages of the OPIL RAN interface (docs/contract.md §2) and ids
    "Id": ("vcran.core.opil.ids", "Id"),
    "id_for": ("vcran.core.opil.ids", "id_for"),
    "MotionAssignment": ("vcran.core.opil.messages", "MotionAssignment"),
    "ActionAssignment": ("vcran.core.opil.messages", "ActionAssignment"),
    "CancelTask": ("vcran.core.opil.messages", "CancelTask"),
    # the boundary between the simulation and a transport
    "Transport": ("vcran.core.wire", "Transport"),
    "Inbound": ("vcran.core.wire", "Inbound"),
    "Publish": ("vcran.core.wire", "Publish"),
    "Frame": ("vcran.core.wire", "Frame"),
    # running a scenario in process (docs/contract.md §9), or into a run folder with a transport of one's own
    "simulate": ("vcran.api", "simulate"),
    "Result": ("vcran.api", "Result"),
    "ManagerError": ("vcran.api", "ManagerError"),
    "run_to": ("vcran.runner", "run_to"),
    "RunFolderError": ("vcran.io.runfolder", "RunFolderError"),
    "RunResult": ("vcran.runner", "RunResult"),
    # reading a run folder back (docs/outputs.md)
    "telemetry_table": ("vcran.io.trace", "telemetry_table"),
    "trace_records": ("vcran.io.trace", "trace_records"),
    # a fleet manager in the loop (docs/contract.md §9)
    "FleetManager": ("vcran.core.opil.manager", "FleetManager"),
    "Handle": ("vcran.core.opil.manager", "OpilHandle"),
    "Fleet": ("vcran.core.manager", "Fleet"),
    "Timer": ("vcran.core.manager", "Timer"),
    "Job": ("vcran.core.scenario", "Job"),
    "JobStream": ("vcran.core.scenario", "JobStream"),
    "LinkSettings": ("vcran.core.scenario", "LinkSettings"),
    "JobRecord": ("vcran.core.jobs", "JobRecord"),
    # many variants and seeds into one KPI table, here or on a Dask cluster (docs/contract.md §10)
    "load_sweep": ("vcran.sweep.spec", "load"),
    "run_sweep": ("vcran.sweep.runs", "run_sweep"),
    "Sweep": ("vcran.sweep.spec", "Sweep"),
    "SweepResult": ("vcran.sweep.runs", "SweepResult"),
    "SweepError": ("vcran.sweep.spec", "SweepError"),
}

#: Literal, so that type checkers and linters read it; a test checks it names exactly _EXPORTS.
__all__ = [
    "__version__",
    "Scenario", "Settings", "RobotConfig", "StationConfig", "ScriptEntry", "Script",
    "load_scenario", "parse_scenario", "ScenarioError",
    "Id", "id_for", "MotionAssignment", "ActionAssignment", "CancelTask",
    "Transport", "Inbound", "Publish", "Frame",
    "simulate", "Result", "ManagerError", "run_to", "RunResult", "RunFolderError",
    "telemetry_table", "trace_records",
    "FleetManager", "Handle", "Fleet", "Timer", "Job", "JobStream", "LinkSettings", "JobRecord",
    "load_sweep", "run_sweep", "Sweep", "SweepResult", "SweepError",
]


def __getattr__(name: str) -> Any:
    try:
        module, attribute = _EXPORTS[name]
    except KeyError:
        raise AttributeError(f"module 'vcran' has no attribute {name!r}") from None
    value = getattr(importlib.import_module(module), attribute)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


if TYPE_CHECKING:  # what type checkers and IDEs see; the same names as _EXPORTS
    from vcran.api import ManagerError, Result, simulate
    from vcran.core.jobs import JobRecord
    from vcran.core.manager import Fleet, Timer
    from vcran.core.opil.ids import Id, id_for
    from vcran.core.opil.manager import FleetManager
    from vcran.core.opil.manager import OpilHandle as Handle
    from vcran.core.opil.messages import ActionAssignment, CancelTask, MotionAssignment
    from vcran.core.scenario import (
        Job,
        JobStream,
        LinkSettings,
        RobotConfig,
        Scenario,
        Script,
        ScriptEntry,
        Settings,
        StationConfig,
    )
    from vcran.core.wire import Frame, Inbound, Publish, Transport
    from vcran.io.runfolder import RunFolderError
    from vcran.io.scenario_file import ScenarioError
    from vcran.io.scenario_file import load as load_scenario
    from vcran.io.scenario_file import parse as parse_scenario
    from vcran.io.trace import telemetry_table, trace_records
    from vcran.runner import RunResult, run_to
    from vcran.sweep.runs import SweepResult, run_sweep
    from vcran.sweep.spec import Sweep, SweepError
    from vcran.sweep.spec import load as load_sweep
