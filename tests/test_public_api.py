"""The public API (``vcran/__init__.py``): every exported name resolves, and importing it stays light."""

from __future__ import annotations

import subprocess
import sys

import pytest

import vcran
from tests.conftest import ROOT


def test_all_names_exactly_the_exports_and_each_resolves():
    assert set(vcran.__all__) - {"__version__"} == set(vcran._EXPORTS)
    for name in vcran.__all__:
        assert getattr(vcran, name) is not None, name


def test_an_export_is_the_object_of_its_layer():
    from vcran.core.scenario import Scenario
    from vcran.io.scenario_file import load

    assert vcran.Scenario is Scenario
    assert vcran.load_scenario is load


def test_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no_such_thing"):
        vcran.no_such_thing  # noqa: B018


def test_import_vcran_loads_no_simulation_until_a_name_is_used():
    code = (
        "import sys, vcran; heavy = [m for m in ('simpy', 'numpy', 'httpx') if m in sys.modules]; "
        "s = vcran.load_scenario('scenarios/demo.toml'); print(heavy, s.robots[0].id)"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            cwd=ROOT)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["[]", "robot_1"]
