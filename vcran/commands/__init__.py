"""Subcommands of ``vcran`` (see :mod:`vcran.cli`), and what several of them share."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from vcran.core.scenario import Scenario

#: The scenarios shipped in the package (vcran/scenarios; a test keeps this list in step with it).
BUNDLED = ("battery", "corridor", "crossing", "demo", "faults", "vda5050-warehouse", "vda5050", "warehouse-faults",
           "warehouse-traffic", "warehouse")


#: What ``--manager`` adds to each command's help: which options the class gets (vcran.api.manager_options).
MANAGER_OPTIONS = "; it gets the scenario's [manager] options only if it is the class the scenario names"


class CommandError(Exception):
    """A command cannot go on: ``main`` prints ``vcran COMMAND: message`` and returns ``code``."""

    def __init__(self, message: str, code: int = 2) -> None:
        super().__init__(message)
        self.code = code


def check_positive(option: str, value: float) -> None:
    """A CommandError (exit 2) unless ``value`` is a positive finite number: ``inf`` for a speed factor or a
    poll interval divided by zero or overflowed deep in a run, and ``nan`` compares false with everything."""
    if not (math.isfinite(value) and value > 0):
        raise CommandError(f"{option} must be a finite number above 0, got {value:g}")


def check_out(path: Path) -> None:
    """A CommandError (exit 2) unless ``--out`` may receive a run (missing, empty or a vcran run folder)."""
    from vcran.io.runfolder import RunFolderError
    from vcran.io.runfolder import check_out as check

    try:
        check(path)
    except RunFolderError as exc:
        raise CommandError(str(exc)) from None


def add_scenario_argument(parser: argparse.ArgumentParser, what: str) -> None:
    """The SCENARIO argument every scenario command takes, with the same words in every ``--help``."""
    parser.add_argument("scenario", type=Path, metavar="SCENARIO",
                        help=f"scenario file (TOML){what}, or a bundled scenario by name: {', '.join(BUNDLED)}")


def load_scenario(path: Path, mode: str | None) -> Scenario:
    """The scenario at ``path``, or a CommandError (exit 2) naming the file, the entry and the field; also
    for a scenario whose protocol the simulation does not host in ``mode`` (what the command runs; None: a
    scripted run, :func:`vcran.runner.check_protocol`), before a command connects to anything."""
    from vcran.io.scenario_file import ScenarioError, load

    try:
        scenario = load(path)
    except ScenarioError as exc:
        raise CommandError(str(exc)) from None
    check_mode(scenario, mode)
    return scenario


def check_mode(scenario: Scenario, mode: str | None) -> None:
    """A CommandError (exit 2) for a scenario whose protocol the simulation does not host in ``mode``
    (:func:`vcran.runner.check_protocol`): for a command that knows its mode only once the scenario is read."""
    from vcran.io.scenario_file import ScenarioError
    from vcran.runner import check_protocol

    try:
        check_protocol(scenario, mode)
    except ScenarioError as exc:
        raise CommandError(str(exc)) from None
