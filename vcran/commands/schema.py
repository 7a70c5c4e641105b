"""``vcran schema scenario``: the JSON Schema of scenario files, for editors and validators (docs/scenarios.md "JSON Schema for editors")."""

from __future__ import annotations

import argparse
import json
import sys

HELP = "print the JSON Schema of scenario files (editors and TOML language servers validate with it)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("format", choices=("scenario",), help="which file format: scenario (TOML scenario files)")


def run(args: argparse.Namespace) -> int:
    from vcran.io.scenario_schema import scenario_schema

    json.dump(scenario_schema(), sys.stdout, indent=2)
    sys.stdout.write("\n")
    return 0
