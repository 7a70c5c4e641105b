"""Subcommands of ``vcran`` (see :mod:`vcran.cli`), and what several of them share."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from vcran.scenario import Scenario


def load_scenario(path: Path) -> Scenario:
    """The scenario at ``path``, or a CommandError (exit 2) naming the file, the entry and the field."""
    from vcran.cli import CommandError
    from vcran.scenario import ScenarioError, load

    try:
        return load(path)
    except ScenarioError as exc:
        raise CommandError(str(exc)) from None
