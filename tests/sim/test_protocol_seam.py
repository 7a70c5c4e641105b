"""The protocol seam in the simulation (issue 30 item 5, docs/protocols.md): the registry, and the import
contract that keeps every shared module of vcran/sim free of any protocol."""

from __future__ import annotations

import importlib
import tomllib

import pytest

from tests.conftest import ROOT
from vcran.sim.protocols import PROTOCOLS, glue

PROTOCOL_PACKAGES = {"opil", "vda5050"}


def test_every_shared_simulation_module_is_under_the_contract():
    """A module added to vcran/sim outside a protocol's package is shared, so the contract must list it
    (a forbidden contract only checks the modules it names)."""
    contracts = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]["contracts"]
    (contract,) = [c for c in contracts if c["name"] == "The shared simulation imports no protocol"]
    shared = {f"vcran.sim.{p.stem}" for p in (ROOT / "vcran" / "sim").glob("*.py") if p.stem != "__init__"}
    shared |= {f"vcran.sim.{p.name}" for p in (ROOT / "vcran" / "sim").iterdir()
               if p.is_dir() and p.name not in PROTOCOL_PACKAGES and (p / "__init__.py").exists()}
    assert set(contract["source_modules"]) == shared
    assert {"vcran.sim.opil", "vcran.core.opil", "vcran.core.vda5050"} <= set(contract["forbidden_modules"])


def test_each_registered_protocol_has_a_glue_factory():
    assert "opil" in PROTOCOLS
    for name, path in PROTOCOLS.items():
        assert callable(importlib.import_module(path).glue), name


def test_an_unknown_protocol_is_named_with_the_known_ones():
    with pytest.raises(ValueError, match=r"unknown protocol 'mqtt'; known: opil"):
        glue("mqtt")
