"""What a pip user gets (issue 16): the bundled scenarios, and the wheel itself installed into a fresh venv.

The wheel test needs pip to reach PyPI (or its cache) for vcran's dependencies: it is marked ``network``
(``pytest -m "not network"`` leaves it out).
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import venv
import zipfile
from pathlib import Path

import pytest

from tests.conftest import ROOT
from vcran import __version__, cli
from vcran.commands import BUNDLED
from vcran.io.scenario_file import bundled, load


def test_bundled_scenarios_are_the_repository_scenarios() -> None:
    assert bundled() == {p.stem: p for p in sorted((ROOT / "vcran" / "scenarios").glob("*.toml"))}
    assert {name: p.read_bytes() for name, p in bundled().items()} == \
           {p.stem: p.read_bytes() for p in (ROOT / "scenarios").glob("*.toml")}


@pytest.mark.parametrize("command", ["run", "live", "manage", "send", "orion", "fuzz"])
def test_every_scenario_command_names_the_bundled_scenarios_in_its_help(command: str,
                                                                        capsys: pytest.CaptureFixture[str]) -> None:
    assert tuple(bundled()) == BUNDLED
    with pytest.raises(SystemExit) as exit_:
        cli.main([command, "--help"] if command != "orion" else [command, "init", "--help"])
    assert exit_.value.code == 0
    # argparse wraps lines, also after a hyphen ("warehouse-" / "faults")
    usage = re.sub(r"(?<=\w-) (?=\w)", "", " ".join(capsys.readouterr().out.split()))
    assert "SCENARIO" in usage and f"a bundled scenario by name: {', '.join(BUNDLED)}" in usage


def test_a_bundled_name_runs_from_any_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", "demo", "--out", "out", "--quiet"]) == 0
    summary = json.loads((tmp_path / "out" / "summary.json").read_text(encoding="utf-8"))
    assert summary["scenario"] == "demo"
    assert capsys.readouterr() == ("", "")


def test_a_file_of_that_name_wins_over_the_bundled_one(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "demo").write_text('[simulation]\nname = "mine"\nduration = 1.0\n[[robots]]\nid = "r"\n',
                                   encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    assert load("demo").settings.name == "mine"


def test_an_unknown_name_lists_the_bundled_ones(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", "dmeo", "--out", "out"]) == 2
    assert capsys.readouterr().err == "vcran run: dmeo: no such file (and no bundled scenario of that name; bundled: battery, corridor, crossing, demo, faults, vda5050-warehouse, vda5050, warehouse-faults, warehouse-traffic, warehouse)\n"


# --- the wheel ---------------------------------------------------------------------------------------------


def _run(argv: list[str], cwd: Path, check: bool = True,
         extra: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env.update(extra or {})
    result = subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True, timeout=600)
    if check:
        assert result.returncode == 0, f"{argv}: exit {result.returncode}\n{result.stdout}\n{result.stderr}"
    return result


@pytest.mark.slow
@pytest.mark.network
def test_the_wheel_installs_and_runs_outside_the_repository(tmp_path: Path) -> None:
    dist, home = tmp_path / "dist", tmp_path / "elsewhere"
    home.mkdir()
    _run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(dist), str(ROOT)], cwd=home)
    (wheel,) = dist.glob("vcran-*.whl")
    assert wheel.name.endswith("-py3-none-any.whl")  # plain Python: nothing compiled at install (issue 30)
    names = zipfile.ZipFile(wheel).namelist()
    assert {"vcran/py.typed", "transports/py.typed", *(f"vcran/scenarios/{n}.toml" for n in BUNDLED)} <= set(names)
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names)
    schemas = "vcran/core/vda5050/schemas"  # the official VDA 5050 schemas, each copy with its licence (docs/contract.md §11)
    assert {f"{schemas}/{v}/{f}" for v in ("2.0.0", "2.1.0") for f in ("LICENSE.txt", "order.schema", "state.schema")
            } | {f"{schemas}/2.0.0/factsheet.json", f"{schemas}/2.1.0/factsheet.schema"} <= set(names)
    assert not [n for n in names if n.startswith("tests/") or "/tests/" in n or "conftest" in n]
    metadata = zipfile.ZipFile(wheel).read(next(n for n in names if n.endswith(".dist-info/METADATA"))).decode()
    assert "License-Expression: Apache-2.0" in metadata and "Provides-Extra: fuzz" in metadata

    venv.create(tmp_path / "venv", with_pip=True)
    bin_ = tmp_path / "venv" / "bin"
    _run([str(bin_ / "pip"), "install", "-q", str(wheel)], cwd=home)
    vcran = str(bin_ / "vcran")
    assert _run([vcran, "--version"], cwd=home).stdout == f"vcran {__version__}\n"
    assert not [n for n in names if n.endswith((".so", ".c"))]
    assert _run([vcran, "--help"], cwd=home).stdout.startswith("usage: vcran")
    _run([vcran, "run", "demo", "--out", "out", "--quiet"], cwd=home)
    refused = _run([str(bin_ / "python"), "-c", "from vcran.core.vda5050 import codec, enums; "
                    "print(codec.decode(enums.Topic.ORDER, b'{}', enums.Version.V2_0_0))"], cwd=home)
    assert refused.stdout == "order: $.headerId: required field missing\n"  # the schemas load from the wheel
    assert json.loads((home / "out" / "summary.json").read_text(encoding="utf-8"))["scenario"] == "demo"
    _run([vcran, "run", "warehouse", "--out", "loop", "--quiet"], cwd=home)  # the shipped fleet manager too
    jobs = json.loads((home / "loop" / "summary.json").read_text(encoding="utf-8"))["jobs"]
    assert jobs["completed"] == jobs["arrived"] > 0
    assert json.loads(_run([vcran, "schema", "scenario"], cwd=home).stdout)["title"] == "vcran scenario file"

    without = _run([vcran, "fuzz", "demo", "--examples", "5"], cwd=home, check=False)
    assert (without.returncode, without.stdout) == (2, "")
    assert without.stderr == ("vcran fuzz: fuzzing needs hypothesis, which is not installed: "
                              "pip install 'vcran[fuzz]'\n")

    _run([str(bin_ / "pip"), "install", "-q", f"vcran[fuzz] @ {wheel.as_uri()}"], cwd=home)
    fuzz = _run([vcran, "fuzz", "demo", "--examples", "5", "--fast"], cwd=home)
    assert "5 examples" in fuzz.stdout + fuzz.stderr
    plugin = _run([str(bin_ / "python"), "-c", "from importlib.metadata import entry_points; "
                   "print([e.value for e in entry_points(group='pytest11', name='vcran')])"], cwd=home)
    assert plugin.stdout.strip() == "['vcran.testing.pytest_plugin']"
