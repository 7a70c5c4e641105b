"""The compiled core (vcran/_native.py, issue 14): the same bytes as the pure modules, never stale, never
required."""

from __future__ import annotations

import json
import os
import shlex
import shutil
import subprocess
import sys
import sysconfig
from importlib.machinery import EXTENSION_SUFFIXES
from pathlib import Path

import pytest

from tests.conftest import ROOT
from vcran import _native

PACKAGE = ROOT / "vcran"
FILES = ("trace.jsonl.zst", "legs.npy", "events.jsonl.zst", "summary.json")


def _child(code: str, pure: bool, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != _native.PURE_ENV}
    if pure:
        env[_native.PURE_ENV] = "1"
    return subprocess.run([sys.executable, "-c", code], cwd=cwd, env=env, capture_output=True, text=True,
                          check=True)


def test_the_install_runs_the_compiled_core_where_a_c_compiler_is():
    """What CI installs (the README's test command) is the compiled core: a build that silently fell back to
    pure Python, or one left stale by an edit, fails here rather than passing the suite on other code."""
    compiler = shlex.split(sysconfig.get_config_var("CC") or "cc")[0]
    if shutil.which(compiler) is None:
        assert _native.MODE == "pure"  # and nothing else needs checking: the pure install is the whole package
        return
    assert (_native.MODE, _native.REASON) == ("compiled", ""), (
        f"the compiled core is not in use ({_native.REASON or 'not built'}): reinstall, pip install -e '.[test]'")


@pytest.mark.slow
def test_compiled_and_pure_modules_write_the_same_bytes(tmp_path):
    """Every output file of the bundled scenarios (the closed loop, faults, battery, collisions) and of a
    generated fleet, run by both; the children say which modules they ran."""
    gen = tmp_path / "gen10.toml"
    gen.write_text(subprocess.run([sys.executable, "-m", "vcran", "gen", "--robots", "10", "--hours", "0.25",
                                   "--seed", "1"], check=True, capture_output=True, text=True).stdout)
    scenarios = ["demo", "warehouse", *(str(ROOT / "scenarios" / f"{n}.toml") for n in ("faults", "battery", "crossing")),
                 str(gen)]
    code = ("import sys, vcran.sim.robot as robot, vcran.core.ranlogic as logic\n"
            "from vcran.cli import main\n"
            "print(robot.__file__, logic.__file__)\n"
            "for i, s in enumerate(sys.argv[1:]):\n"
            "    assert main(['run', s, '--out', f'out{i}', '--quiet']) == 0\n")
    files = {}
    for pure in (False, True):
        where = tmp_path / ("pure" if pure else "default")
        where.mkdir()
        ran = _child(code.replace("sys.argv[1:]", repr(scenarios)), pure, where).stdout.split()
        compiled = not pure and _native.MODE == "compiled"
        assert all(f.endswith(".py") != compiled for f in ran)
        files[pure] = {(i, f): (where / f"out{i}" / f).read_bytes() for i in range(len(scenarios)) for f in FILES}
    assert files[False] == files[True]


# --- deciding, on a package folder of its own ------------------------------------------------------------------


@pytest.fixture
def package(tmp_path: Path) -> Path:
    """A copy of the compiled modules' sources, with an extension file beside each and the group's."""
    for module in _native.MODULES:
        target = _native.source(tmp_path, module)
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(_native.source(PACKAGE, module), target)
        (target.parent / (target.stem + EXTENSION_SUFFIXES[0])).write_bytes(b"")
    (tmp_path / ("_core__mypyc" + EXTENSION_SUFFIXES[0])).write_bytes(b"")
    (tmp_path / _native.BUILD_FILE).write_text(json.dumps({"digest": _native.digest(tmp_path)}))
    return tmp_path


def test_a_current_build_is_used(package):
    assert _native.decide(package, {}) == ("compiled", "")
    assert _native.decide(package, {_native.PURE_ENV: "0"}) == ("compiled", "")


def test_vcran_pure_runs_the_pure_modules_whatever_is_built(package):
    assert _native.decide(package, {_native.PURE_ENV: "1"}) == ("pure", "VCRAN_PURE=1")


def test_an_edited_source_makes_the_whole_build_stale(package):
    robot = _native.source(package, "vcran.sim.robot")
    robot.write_text(robot.read_text() + "# edited\n")
    assert _native.decide(package, {}) == ("pure", "its sources changed since it was compiled")


def test_a_partial_or_unrecorded_build_is_not_used(package):
    (package / _native.BUILD_FILE).write_text("{")
    assert _native.decide(package, {}) == ("pure", f"{_native.BUILD_FILE} is missing or unreadable")
    (package / _native.BUILD_FILE).unlink()
    assert _native.decide(package, {})[0] == "pure"
    (_native.source(package, "vcran.core.tasks").with_name("tasks" + EXTENSION_SUFFIXES[0])).unlink()
    assert _native.decide(package, {}) == ("pure", "only 10 of the compiled core's 11 files are installed")


def test_no_build_at_all_is_a_pure_install_without_a_reason(package):
    for so in package.rglob("*" + EXTENSION_SUFFIXES[0]):
        so.unlink()
    assert _native.decide(package, {}) == ("pure", "")
    assert _native.decide(package, {_native.PURE_ENV: "1"}) == ("pure", "")
