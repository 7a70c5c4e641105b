"""What ``vcran run`` imports (issue 14: start-up counts when a small run takes well under a second).

A scripted run of robots without batteries whose footprints' boxes never meet samples nothing: it needs
neither numpy (the fleet's sweep, vcran.core.sampling; the exact footprint test, vcran.core.overlap; the
leg log is written without it), nor shapely, nor the closed loop, nor the NGSI codec, nor any optional
extra. The static half of this (no HTTP, plotting, fuzzing or cluster library anywhere on the run path)
is an import-linter contract in pyproject.toml; this test checks what a real run loads, function-level
imports included.
"""

from __future__ import annotations

import json
import subprocess
import sys

#: Modules (and their submodules) the demo's run must not load.
NOT_NEEDED = (
    "numpy", "shapely", "httpx", "matplotlib", "hypothesis", "dask", "polars", "pandas",
    "vcran.sim.loop", "vcran.sim.opil.loop", "vcran.sim.link", "vcran.core.manager", "vcran.core.opil.manager", "vcran.core.jobs", "vcran.core.opil.codec",
    "vcran.report", "vcran.broker", "vcran.sweep", "vcran.testing", "transports.orion",
    "vcran.core.sampling", "vcran.core.overlap", "vcran.sim.power",
    # VDA 5050's schema validators (0.1 s to import): a VDA 5050 script's messages are checked only when a
    # scenario has them (vcran.io.scenario_vda5050)
    "jsonschema", "vcran.core.vda5050.codec", "vcran.core.vda5050.validation",
)


def test_the_demo_runs_without_loading_what_it_does_not_use(tmp_path):
    # the demo: one robot with the default (rectangular, convex) footprint, a message script, no manager
    code = (
        "import json, sys\n"
        "from vcran.cli import main\n"
        f"code = main(['run', 'demo', '--out', {str(tmp_path / 'out')!r}, '--quiet'])\n"
        f"loaded = sorted(m for m in sys.modules if any(m == n or m.startswith(n + '.') for n in {NOT_NEEDED!r}))\n"
        "print(json.dumps({'code': code, 'loaded': loaded}))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    result = json.loads(done.stdout.splitlines()[-1])
    assert result == {"code": 0, "loaded": []}
    assert (tmp_path / "out" / "summary.json").is_file()


def test_python_m_vcran_exits_with_the_commands_status(tmp_path):
    # the console entry point freezes the heap before exiting (vcran.cli.console): the run folder is complete
    # and the status is the command's, 0 for a run, 2 for a scenario that does not exist
    ok = subprocess.run([sys.executable, "-m", "vcran", "run", "demo", "--out", str(tmp_path / "out"), "--quiet"],
                        capture_output=True, text=True)
    assert ok.returncode == 0, ok.stderr
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["robots"]
    bad = subprocess.run([sys.executable, "-m", "vcran", "run", str(tmp_path / "missing.toml"), "--out",
                          str(tmp_path / "other")], capture_output=True, text=True)
    assert bad.returncode == 2
    assert bad.stderr.startswith("vcran run: ")
