"""The model packed into the page: one compressed buffer of a JSON part and binary columns (docs/contract.md §13).

A 100-robot, 8-hour run has 127 thousand legs and 250 thousand state changes: as JSON text that is tens
of megabytes, and slow to parse. So every long column is a little-endian typed array (what JavaScript's
``Float64Array`` and friends view without copying), the short and irregular parts (names, stations,
jobs) are JSON, and the whole is one zlib stream (what the browser's own ``DecompressionStream("deflate")``
reads: nothing to fetch, no library), base64 in the page. Times and coordinates stay float64, so the page
evaluates the legs from the very numbers the run wrote.

Layout of the decompressed buffer: a little-endian uint32 ``n``, ``n`` bytes of UTF-8 JSON (the meta part,
whose ``columns`` maps each column's name to ``[dtype, byte offset, length]``), zero bytes up to the next
multiple of 8, then the columns, each at an offset (counted from there) that is a multiple of 8. The same model packs to the same bytes (zlib is deterministic).
"""

from __future__ import annotations

import base64
import json
import math
import struct
import zlib
from typing import Any

import numpy as np

from vcran.view.incidents import KINDS
from vcran.view.model import Steps, ViewModel
from vcran.view.poses import LEG, row_kinds

FORMAT, VERSION = "vcran-view", 1
DTYPES = {"f64": "<f8", "f32": "<f4", "i32": "<i4", "u32": "<u4", "i16": "<i2", "u16": "<u2", "u8": "u1"}
LEVEL = 6


def payload(model: ViewModel) -> str:
    """The model as the page embeds it: base64 of the zlib-compressed buffer (module docstring)."""
    return base64.b64encode(zlib.compress(packed(model), LEVEL)).decode("ascii")


def packed(model: ViewModel) -> bytes:
    columns: dict[str, tuple[str, np.ndarray]] = {}
    meta = _meta(model, columns)
    body = bytearray()
    directory = {}
    for name, (code, array) in columns.items():
        data = np.ascontiguousarray(array, dtype=DTYPES[code]).tobytes()
        directory[name] = [code, len(body), int(array.size)]
        body += data + b"\0" * (-len(data) % 8)
    meta["columns"] = directory
    text = json.dumps(_finite(meta), separators=(",", ":"), ensure_ascii=False, allow_nan=False).encode()
    head = struct.pack("<I", len(text)) + text
    return head + b"\0" * (-len(head) % 8) + bytes(body)


def _meta(m: ViewModel, columns: dict[str, tuple[str, np.ndarray]]) -> dict[str, Any]:
    def steps(name: str, s: Steps, code: str) -> None:
        columns[f"{name}.offsets"] = ("u32", s.offsets)
        columns[f"{name}.t"] = ("f64", s.t)
        columns[f"{name}.value"] = (code, s.value)

    limits = _legs(m, columns)
    steps("states", m.states, "u8")
    steps("current", m.current, "i32")
    steps("loads", m.loads, "i16")
    steps("batteries", m.batteries, "f32")
    steps("errors", m.errors, "i32")
    steps("parts", m.parts, "i32")
    columns["parts.room"] = ("i32", m.parts_room)
    t = m.tasks
    for name, code, array in (("robot", "i32", t.robot), ("label", "i32", t.label), ("queued", "f64", t.queued),
                              ("started", "f64", t.started), ("end", "f64", t.end), ("outcome", "u8", t.outcome)):
        columns[f"tasks.{name}"] = (code, array)
    kinds = list(KINDS)
    columns["incidents.t"] = ("f64", np.array([i.t for i in m.incidents], dtype=np.float64))
    columns["incidents.kind"] = ("u8", np.array([kinds.index(i.kind) for i in m.incidents], dtype=np.uint8))
    columns["incidents.robot"] = ("i32", np.array([i.robot for i in m.incidents], dtype=np.int32))
    return {
        "format": FORMAT, "version": VERSION, "title": m.title, "scenario": m.scenario, "seed": m.seed,
        "end": m.end, "complete": m.complete, "source": m.source, "notes": m.notes,
        "geometry": m.geometry,
        "robots": [{"id": r.id, "pose": list(r.pose), "footprint": [list(p) for p in r.footprint],
                    "capacity": r.capacity, "carrying": r.carrying} for r in m.robots],
        "stations": [{"id": s.id, "x": s.position[0], "y": s.position[1], "reach": s.reach,
                      "area": [list(p) for p in s.area], "capacity": s.capacity, "every": s.produce_every,
                      "start": s.produce_start, "charger": s.charger} for s in m.stations],
        "areas": [{"robot": i, "points": [list(p) for p in points]} for i, points in m.areas],
        "roadmap": m.roadmap,
        "states": m.state_names, "outcomes": t.outcomes, "taskLabels": t.labels, "errorTexts": m.error_texts,
        "limits": limits,
        "jobs": [{"id": j.id, "arrived": j.arrived, "pickup": j.pickup, "dropoff": j.dropoff, "priority": j.priority,
                  "deadline": j.deadline, "tasks": list(j.tasks), "robots": list(j.robots), "status": j.status,
                  "ended": j.ended, "lead": j.lead_time, "reason": j.reason} for j in m.jobs],
        "incidentKinds": [{"kind": k, "label": label, "colour": colour} for k, (label, colour) in KINDS.items()],
        "incidentTexts": [i.text for i in m.incidents],
    }


def _legs(m: ViewModel, columns: dict[str, tuple[str, np.ndarray]]) -> list[list[float]]:
    """The leg log as columns; the limits (the same few for a whole fleet) as a table with an index per
    row, and ``t0`` only where it is not ``t`` (a leg resumed after a hold): as two sparse columns."""
    rows = m.legs if m.legs is not None else np.zeros(0, dtype=[(c, "<f8") for c in
                                                                 ("t", "robot", "t0", "x0", "y0", "theta0", "x", "y",
                                                                  "theta", "speed", "accel", "decel", "turn_rate")])
    columns["legs.offsets"] = ("u32", m.leg_offsets)
    kinds = row_kinds(rows)
    columns["legs.kind"] = ("u8", kinds)
    for name in ("t", "x0", "y0", "theta0", "x", "y", "theta"):
        columns[f"legs.{name}"] = ("f64", rows[name])
    moving = kinds == LEG
    shifted = np.flatnonzero(moving & (rows["t0"] != rows["t"]))
    columns["legs.resumed"] = ("u32", shifted)
    columns["legs.resumedT0"] = ("f64", rows["t0"][shifted])
    limits = np.column_stack([rows[c] for c in ("speed", "accel", "decel", "turn_rate")])[moving]
    table, inverse = np.unique(limits, axis=0, return_inverse=True)
    if len(table) > 65535:
        raise ValueError("more than 65535 distinct leg limits")
    index = np.zeros(len(rows), dtype=np.uint16)
    index[moving] = inverse.reshape(-1)
    columns["legs.limits"] = ("u16", index)
    return [[float(v) for v in key] for key in table]


def _finite(value: Any) -> Any:
    """JSON has no NaN or infinity: None stands for them."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    return value
