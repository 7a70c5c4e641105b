"""How long vcran's hypothesis profiles take on vcran's own fuzz tests (docs/fuzzing.md, "Profiles").

    python benchmarks/bench_fuzz.py                                   # profile vcran, tests/testing/test_fuzz_*.py
    python benchmarks/bench_fuzz.py --profile vcran-deep tests/testing/test_fuzz_ranlogic.py

Runs ``pytest -q --hypothesis-profile=PROFILE FILES`` in a child process, once, and prints its wall time,
its CPU time (user + system, from the child's resource usage: what a CI job bills, and much less swayed
by a shared machine's load than wall time) and its peak memory, with the Python, the machine and the
load average it ran under. The child runs in one process (no xdist): the figures are for one core.
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--profile", default="vcran", help="hypothesis profile (default: vcran)")
    parser.add_argument("files", nargs="*", help="test files (default: tests/testing/test_fuzz_*.py)")
    args = parser.parse_args()
    files = args.files or sorted(str(p.relative_to(ROOT)) for p in (ROOT / "tests" / "testing").glob("test_fuzz_*.py"))
    command = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:randomly",
               f"--hypothesis-profile={args.profile}", *files]
    load = os.getloadavg()[0]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    last = (done.stdout.strip().splitlines() or ["(no output)"])[-1]
    print(f"# hypothesis profile {args.profile}: {' '.join(files)}\n")
    print(f"Python {platform.python_version()} on {platform.machine()}, {os.cpu_count()} CPUs, load average "
          f"{load:.1f} at the start\n")
    print("| wall (s) | CPU (s) | peak memory (MiB) | pytest |")
    print("|---:|---:|---:|---|")
    print(f"| {wall:.1f} | {cpu:.1f} | {after.ru_maxrss / 1024:.0f} | {last} |")
    if done.returncode != 0:
        raise SystemExit(f"pytest exited {done.returncode}:\n{done.stdout[-2000:]}{done.stderr[-2000:]}")


if __name__ == "__main__":
    main()
