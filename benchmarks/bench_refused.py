"""Live mode against an Orion that refuses or drops what vcran sends: requests, bytes, log lines, CPU.

    python benchmarks/bench_refused.py                          # this tree
    git worktree add ../vcran-before HEAD~10                     # any older checkout to compare with
    python benchmarks/bench_refused.py --tree ../vcran-before   # both trees per mode, with ratios
    python benchmarks/bench_refused.py --robots 20 --seconds 10 --modes 204 401 429 404-drop

A fake Orion on loopback answers every request the same way (``--modes``): ``204`` (the baseline: an
Orion that takes everything), ``401`` (an auth proxy whose token expired), ``429`` (rate limited,
``Retry-After: 2``), ``404-drop`` (alternately a 404 and a connection dropped without an answer). For
each mode ``vcran live`` (polling) runs a generated fleet at factor 1 for ``--seconds`` wall seconds and
is stopped with SIGINT; the table counts the batch updates (``POST /v2/op/update``) and reads it sent,
the bytes of its updates, the log lines it wrote and its CPU time. With ``--tree``, each mode runs with
both source trees back to back (same machine, same minute), and the ratios compare them.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import signal
import subprocess
import sys
import tempfile
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


class FakeOrion:
    def __init__(self, mode: str) -> None:
        self.mode = mode
        self.counts = {"updates": 0, "update_bytes": 0, "reads": 0, "other": 0}
        self.lock = threading.Lock()
        self.flip = 0
        fake = self

        class Handler(BaseHTTPRequestHandler):
            protocol_version = "HTTP/1.1"

            def _serve(self) -> None:
                length = int(self.headers.get("Content-Length") or 0)
                body = self.rfile.read(length) if length else b""
                with fake.lock:
                    if self.path.startswith("/v2/op/update"):
                        fake.counts["updates"] += 1
                        fake.counts["update_bytes"] += len(body)
                    elif self.command == "GET" and self.path.startswith("/v2/entities"):
                        fake.counts["reads"] += 1
                    else:
                        fake.counts["other"] += 1
                    fake.flip += 1
                    flip = fake.flip
                mode = fake.mode
                if mode == "404-drop":
                    if flip % 2:
                        self.close_connection = True  # no answer at all
                        return
                    mode = "404"
                if mode == "204":
                    status, payload, headers = (200, b"[]", {}) if self.command == "GET" else (204, b"", {})
                else:
                    status = int(mode)
                    names = {401: "Unauthorized", 404: "NotFound", 429: "TooManyRequests"}
                    payload = json.dumps({"error": names[status], "description": "benchmark"}).encode()
                    headers = {"Retry-After": "2"} if status == 429 else {}
                self.send_response(status)
                for name, value in headers.items():
                    self.send_header(name, value)
                self.send_header("Content-Length", str(len(payload)))
                if payload:
                    self.send_header("Content-Type", "application/json")
                self.end_headers()
                self.wfile.write(payload)

            do_GET = do_POST = do_DELETE = do_PATCH = _serve

            def log_message(self, *args: object) -> None:
                pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.server.daemon_threads = True
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}"
        threading.Thread(target=self.server.serve_forever, daemon=True).start()

    def stop(self) -> None:
        self.server.shutdown()
        self.server.server_close()


def run(tree: Path, mode: str, robots: int, seconds: float, work: Path) -> dict[str, float]:
    sys.path.insert(0, str(ROOT))
    from vcran.io.gen import generate

    scenario = work / f"fleet-{robots}.toml"
    scenario.write_text(generate(robots, 1.0, 1))
    orion = FakeOrion(mode)
    env = {**os.environ, "PYTHONPATH": str(tree), "PYTHONUNBUFFERED": "1"}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = work / f"out-{mode}-{tree.name}"
    live = subprocess.Popen([sys.executable, "-m", "vcran", "live", str(scenario), "--orion", orion.url,
                             "--out", str(out)], cwd=tree, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    time.sleep(seconds)
    live.send_signal(signal.SIGINT)
    try:
        _, err = live.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        live.kill()
        _, err = live.communicate()
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    orion.stop()
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    log_lines = sum(1 for line in err.splitlines() if line.startswith("vcran:"))
    return {**orion.counts, "log_lines": log_lines, "cpu": cpu, "exit": live.returncode}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--robots", type=int, default=20)
    parser.add_argument("--seconds", type=float, default=10.0, help="wall seconds per run")
    parser.add_argument("--modes", nargs="+", default=["204", "401", "429", "404-drop"])
    parser.add_argument("--tree", type=Path, help="another checkout of vcran to compare with (e.g. main)")
    args = parser.parse_args()
    trees = [ROOT] + ([args.tree.resolve()] if args.tree else [])
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for mode in args.modes:
            for tree in trees:
                figures = run(tree, mode, args.robots, args.seconds, Path(tmp))
                rows.append((mode, tree, figures))
                print(f"{mode} {tree}: {figures}", file=sys.stderr)
    print(f"{args.robots} robots, {args.seconds:g} wall s at factor 1, polling\n")
    print("| Orion answers | tree | updates sent | MB sent | reads | log lines | CPU s | exit |")
    print("|---|---|---|---|---|---|---|---|")
    for mode, tree, f in rows:
        print(f"| {mode} | {tree.name} | {f['updates']:.0f} | {f['update_bytes'] / 1e6:.2f} | {f['reads']:.0f} | "
              f"{f['log_lines']:.0f} | {f['cpu']:.1f} | {f['exit']:.0f} |")
    if args.tree:
        print("\n| Orion answers | updates: other / this | MB: other / this | log lines: other / this | CPU: other / this |")
        print("|---|---|---|---|---|")
        for i in range(0, len(rows), 2):
            mode, _, this = rows[i]
            other = rows[i + 1][2]

            def ratio(key: str, a: dict = this, b: dict = other) -> str:
                return f"{b[key] / a[key]:.1f}x" if a[key] else f"{b[key]:.0f} / 0"

            print(f"| {mode} | {ratio('updates')} | {ratio('update_bytes')} | {ratio('log_lines')} | {ratio('cpu')} |")


if __name__ == "__main__":
    main()
