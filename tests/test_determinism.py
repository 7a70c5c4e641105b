"""SPEC §5: same scenario, same seed -> byte-identical outputs, whatever PYTHONHASHSEED."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from tests.conftest import ROOT

FILES = ("trace.jsonl", "telemetry.bin", "events.jsonl", "summary.json")


def run_cli(args: list[str], hashseed: str, cwd) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONHASHSEED": hashseed}
    return subprocess.run([sys.executable, "-m", "vcran", *args], env=env, cwd=cwd, capture_output=True, text=True)


@pytest.mark.parametrize("scenario", ["demo", "generated"])
def test_outputs_are_byte_identical_across_hash_seeds(tmp_path, scenario):
    if scenario == "demo":
        path = ROOT / "scenarios" / "demo.toml"
    else:
        gen = run_cli(["gen", "--robots", "30", "--hours", "0.05", "--seed", "7"], "0", tmp_path)
        assert gen.returncode == 0, gen.stderr
        path = tmp_path / "fleet.toml"
        path.write_text(gen.stdout)
    outs = []
    for seed in ("1", "4242"):
        out = tmp_path / f"out-{seed}"
        result = run_cli(["run", str(path), "--out", str(out), "--quiet"], seed, tmp_path)
        assert result.returncode == 0, result.stderr
        outs.append(out)
    for name in FILES:
        a, b = (outs[0] / name).read_bytes(), (outs[1] / name).read_bytes()
        assert a == b, f"{name} differs between PYTHONHASHSEED=1 and 4242"
    assert len((outs[0] / "events.jsonl").read_bytes()) > 0


def test_wall_clock_figures_stay_out_of_outputs(tmp_path):
    out = tmp_path / "o"
    result = run_cli(["run", str(ROOT / "scenarios" / "demo.toml"), "--out", str(out)], "0", tmp_path)
    assert "wall time" in result.stdout
    for name in ("summary.json", "events.jsonl"):
        text = (out / name).read_text()
        assert "wall" not in text and "speed" not in text
