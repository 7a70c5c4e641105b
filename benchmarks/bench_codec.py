"""Codec throughput: messages encoded and decoded per second for current_motion and motion_assignment.

Run: ``python benchmarks/bench_codec.py [--seconds S]``. The live transport must publish
``current_motion``, ``assignment_state`` and ``ran_status`` for 1000 robots every second, so the last
lines time exactly that: 1000 entities encoded to wire bytes and split into ``POST /v2/op/update``
bodies. The floor is ``json.dumps``/``json.loads`` of the same attribute as a ready-made dict, measured
in the same run: what serializing alone costs through the dict path.
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from vcran.core.opil.codec import (
    decode_attribute,
    encode_attribute,
    encode_attribute_json,
    encode_entity,
    encode_entity_json,
    split_batch,
)
from vcran.core.opil.ids import id_for
from vcran.core.opil.messages import AssignmentStatus, RanStatus, TaskEnd, Time
from vcran.core.opil.schema import Message

REFERENCE = Path(__file__).resolve().parent.parent / "tests" / "data" / "opil_robot_entity.json"


def rate(fn: Callable[[], Any], seconds: float) -> float:
    """Calls per second: the best of five rounds of about ``seconds / 5`` each."""
    n = 1
    while True:  # find a batch size that takes about a millisecond
        start = time.perf_counter()
        for _ in range(n):
            fn()
        if time.perf_counter() - start > 1e-3:
            break
        n *= 2
    best = float("inf")
    for _ in range(5):
        start, calls, deadline = time.perf_counter(), 0, time.perf_counter() + seconds / 5
        while time.perf_counter() < deadline:
            for _ in range(n):
                fn()
            calls += n
        best = min(best, (time.perf_counter() - start) / calls)
    return 1.0 / best


def compact(value: Any) -> bytes:
    return json.dumps(value, separators=(",", ":"), allow_nan=False).encode()


def attribute_rows(name: str, attr: dict[str, Any]) -> list[tuple[str, Callable[[], Any]]]:
    message = decode_attribute(name, attr)
    wire = compact(attr)
    key_values = attr["value"]
    return [
        ("encode (dicts)", lambda: encode_attribute(name, message)),
        ("encode (dicts) + json.dumps", lambda: compact(encode_attribute(name, message))),
        ("encode_attribute_json (wire text)", lambda: encode_attribute_json(name, message)),
        ("decode normalized", lambda: decode_attribute(name, attr)),
        ("decode keyValues", lambda: decode_attribute(name, key_values, key_values=True)),
        ("json.loads + decode (wire bytes)", lambda: decode_attribute(name, json.loads(wire))),
        ("floor: json.dumps alone", lambda: compact(attr)),
        ("floor: json.loads alone", lambda: json.loads(wire)),
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=1.0, help="time per measurement (default 1)")
    seconds = parser.parse_args().seconds

    entity = json.loads(REFERENCE.read_text())
    print(f"{'attribute':<18} {'operation':<34} {'messages/s':>12}")
    for name in ("current_motion", "motion_assignment"):
        for label, fn in attribute_rows(name, entity[name]):
            print(f"{name:<18} {label:<34} {rate(fn, seconds):>12,.0f}")
        size = len(encode_attribute_json(name, decode_attribute(name, entity[name])))
        print(f"{name:<18} {'wire size (bytes)':<34} {size:>12,}")

    print()
    motion = decode_attribute("current_motion", entity["current_motion"])
    footprint = decode_attribute("robot_description", entity["robot_description"]).footprint  # type: ignore[attr-defined]
    periodic: dict[str, Message] = {
        "current_motion": motion,
        "assignment_state": AssignmentStatus(
            id_for("task_1"), id_for("motion_3"), id_for("action_0"), id_for("motion_2"), id_for("action_9"), footprint
        ),
        "ran_status": RanStatus(
            state="MOTION", current_task_id=id_for("task_1"), queue=(id_for("task_1"), id_for("task_2")), queued=2,
            completed=(id_for("task_0"),), cancelled=(TaskEnd(id_for("task_x"), "timeout", Time(12, 0)),),
        ),
    }  # fmt: skip
    robots = [f"robot_{i}" for i in range(1000)]
    rounds = [
        ("current_motion, dicts + json.dumps", {"current_motion": motion}, encode_entity),
        ("current_motion, encode_entity_json", {"current_motion": motion}, encode_entity_json),
        ("all periodic, encode_entity_json", periodic, encode_entity_json),
    ]
    for label, messages, encode in rounds:

        def fleet_update(messages: dict[str, Message] = messages, encode: Any = encode) -> list[bytes]:
            return split_batch([encode(robot, "ROBOT", messages) for robot in robots])

        per_second = rate(fleet_update, seconds)
        bodies = fleet_update()
        print(
            f"1000 robots, {label:<36}: {1000 / per_second:7.1f} ms per round, {len(bodies):2} bodies "
            f"<= {max(map(len, bodies)):,} bytes ({per_second:,.1f}x the 1 Hz rate)"
        )


if __name__ == "__main__":
    main()
