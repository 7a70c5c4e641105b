"""Byte-identity check for performance work: run a fixed set of scenarios and compare output hashes.

    python benchmarks/check_identical.py record FILE   # write the hashes of this checkout's outputs
    python benchmarks/check_identical.py check FILE    # rerun and compare against FILE (exit 1 on change)

Covers the bundled demo, warehouse, faults, battery and crossing scenarios and two generated fleets
(10 robots x 1 h, 200 robots x 0.25 h, seed 1): trace.jsonl.zst, legs.npy, events.jsonl.zst, summary.json.
"""

from __future__ import annotations

import hashlib
import json
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
VCRAN = [sys.executable, "-m", "vcran"]
FILES = ("trace.jsonl.zst", "legs.npy", "events.jsonl.zst", "summary.json")


def scenarios(tmp: Path) -> dict[str, str]:
    named = {name: name for name in ("demo", "warehouse")}
    for name in ("faults", "battery", "crossing"):
        named[name] = str(ROOT / "scenarios" / f"{name}.toml")
    for robots, hours in ((10, "1"), (200, "0.25")):
        path = tmp / f"gen{robots}.toml"
        path.write_text(subprocess.run([*VCRAN, "gen", "--robots", str(robots), "--hours", hours, "--seed", "1"],
                                       check=True, capture_output=True, text=True).stdout)
        named[f"gen{robots}"] = str(path)
    return named


def hashes() -> dict[str, dict[str, str]]:
    out: dict[str, dict[str, str]] = {}
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        for name, scenario in scenarios(tmp).items():
            folder = tmp / f"out-{name}"
            subprocess.run([*VCRAN, "run", scenario, "--out", str(folder), "--quiet"], check=True)
            out[name] = {f: hashlib.sha256((folder / f).read_bytes()).hexdigest() for f in FILES}
    return out


def main() -> int:
    mode, path = sys.argv[1], Path(sys.argv[2])
    now = hashes()
    if mode == "record":
        path.write_text(json.dumps(now, indent=1))
        return 0
    then = json.loads(path.read_text())
    bad = [(n, f) for n in then for f in FILES if then[n][f] != now[n][f]]
    for n, f in bad:
        print(f"CHANGED {n}/{f}")
    print("identical" if not bad else f"{len(bad)} files changed")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
