"""What VDA 5050's message handling costs (docs/contract.md §11): a received order decoded (orjson, the official schema
through jsonschema, the typed model) for 2, 10 and 50 nodes, against parsing its JSON alone; and a state
message built by a vehicle and encoded, the per-vehicle cost of every state sent.

    .venv/bin/python benchmarks/bench_vda5050.py [--repeat N]

Prints a Markdown table of microseconds per message (the least of ``--repeat`` rounds: a shared machine's
load only ever adds).
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import orjson

from vcran.core.vda5050 import codec
from vcran.core.vda5050.enums import Topic, Version
from vcran.testing.vda5050.harness import Bench
from vcran.testing.vda5050.plans import action, order


def per_call(fn: Callable[[], object], rounds: int, n: int) -> float:
    best = float("inf")
    for _ in range(rounds):
        t = time.perf_counter()
        for _ in range(n):
            fn()
        best = min(best, (time.perf_counter() - t) / n)
    return best * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    print("| message | parse JSON µs | decode + validate µs | ratio |")
    print("|---|---|---|---|")
    for nodes in (2, 10, 50):
        points = [(f"n{i}", float(i), 0.0) for i in range(nodes)]
        o = order("o", 0, points, base=nodes // 2 + 1,
                  node_actions={f"n{i}": [action("pick", f"p{i}", "HARD", stationName="s")] for i in range(0, nodes, 3)})
        raw = codec.encode(o, Version.V2_1_0)
        codec.decode(Topic.ORDER, raw, Version.V2_1_0)  # builds the validator once
        parse = per_call(lambda raw=raw: orjson.loads(raw), args.repeat, 200)  # type: ignore[misc]
        full = per_call(lambda raw=raw: codec.decode(Topic.ORDER, raw, Version.V2_1_0), args.repeat, 200)  # type: ignore[misc]
        print(f"| order, {nodes} nodes ({len(raw)} B) | {parse:.1f} | {full:.0f} | {full / parse:.0f}x |")
    bench = Bench()
    bench.order(order("o", 0, [(f"n{i}", float(i), 0.0) for i in range(10)], base=6))
    vehicle, body = bench.vehicle, bench.body()
    build = per_call(lambda: vehicle.state(1.0, body), args.repeat, 2000)
    state = vehicle.state(1.0, body)
    encode = per_call(lambda: codec.encode(state, Version.V2_1_0), args.repeat, 2000)
    print(f"| state, 9 nodeStates: build | - | {build:.0f} | - |")
    print(f"| state, 9 nodeStates: encode ({len(codec.encode(state, Version.V2_1_0))} B) | - | {encode:.0f} | - |")


if __name__ == "__main__":
    main()
