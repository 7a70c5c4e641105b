"""Live mode against vcran's own broker: request rate, notification-to-effect latency, CPU.

    python benchmarks/bench_live.py                    # 10 and 100 robots, x10, one wall minute each
    python benchmarks/bench_live.py --robots 100 --seconds 60 --factor 10

For each fleet size: ``vcran broker`` and ``vcran live`` (with a subscription) run as separate processes,
``vcran orion init`` creates the entities, and ``vcran send`` plays a generated fleet's script at the
same factor (the fleet manager). ``vcran live`` prints its outbound request rate, the latency from a
notification's arrival to its entry into the simulation (median, p99) and its own CPU time; the table
collects them. Outbound requests per second should track the telemetry rate (factor x 1 Hz), not the
fleet size.
"""

from __future__ import annotations

import argparse
import os
import re
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
VCRAN = [sys.executable, "-m", "vcran"]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def bench(robots: int, seconds: float, factor: float, work: Path) -> dict[str, str]:
    sys.path.insert(0, str(ROOT))
    from vcran.io.gen import generate

    scenario = work / f"live-{robots}.toml"
    scenario.write_text(generate(robots, seconds * factor / 3600.0, 1))
    port = free_port()
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    broker = subprocess.Popen([*VCRAN, "broker", "--port", str(port)], stdout=subprocess.PIPE, text=True, env=env)
    broker.stdout.readline()
    url = f"http://127.0.0.1:{port}"
    try:
        subprocess.run([*VCRAN, "orion", "init", str(scenario), "--orion", url], check=True, capture_output=True)
        live = subprocess.Popen([*VCRAN, "live", str(scenario), "--orion", url, "--out", str(work / f"out-{robots}"),
                                 "--factor", str(factor), "--notify-url", f"http://127.0.0.1:{free_port()}/notify"],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
        time.sleep(1.5)  # subscription in place before the first message
        sender = subprocess.Popen([*VCRAN, "send", str(scenario), "--orion", url, "--factor", str(factor), "--quiet"],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env)
        try:
            out, err = live.communicate(timeout=seconds * 3 + 60)
        except subprocess.TimeoutExpired:
            live.kill()
            raise
        sender.send_signal(signal.SIGINT)
        sender.wait(timeout=10)
    finally:
        broker.send_signal(signal.SIGINT)
        broker.wait(timeout=10)
    if live.returncode != 0:
        raise SystemExit(f"vcran live failed:\n{err}")
    figures = {"robots": str(robots)}
    patterns = {
        "tasks": r"(\d+) task\(s\) completed",
        "wall": r"wall ([\d.]+) s",
        "out_rps": r"outbound ([\d.]+) requests/s",
        "cpu": r"cpu ([\d.]+) s",
        "median_ms": r"median ([\d.]+) ms",
        "p99_ms": r"p99 ([\d.]+) ms",
        "messages": r"ms \((\d+) messages\)",
    }
    for key, pattern in patterns.items():
        match = re.search(pattern, out)
        figures[key] = match.group(1) if match else "?"
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--robots", type=int, nargs="+", default=[10, 100])
    parser.add_argument("--seconds", type=float, default=60.0, help="wall seconds per run")
    parser.add_argument("--factor", type=float, default=10.0)
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.robots:
            rows.append(bench(n, args.seconds, args.factor, Path(tmp)))
    print("| robots | wall s | tasks done | outbound req/s | notification->effect median ms | p99 ms | messages | vcran CPU s | CPU share |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        share = f"{float(r['cpu']) / float(r['wall']):.0%}" if "?" not in (r["cpu"], r["wall"]) else "?"
        print(f"| {r['robots']} | {r['wall']} | {r['tasks']} | {r['out_rps']} | {r['median_ms']} | {r['p99_ms']} | "
              f"{r['messages']} | {r['cpu']} | {share} |")


if __name__ == "__main__":
    main()
