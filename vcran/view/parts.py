"""What each robot carries and each station holds over time, rebuilt from the run (docs/contract.md §4 stations).

No output file holds these as series: the summary has the final counts only. They follow from what the
run did, by the rules AgvAction applies (:func:`vcran.core.stations.perform`): an ``action_finished``
load or unload moved a part between the robot and the station nearest in reach of where it stood
(:class:`vcran.view.poses.Poses`), when the action succeeded, or when it failed only by an injected
action failure (``action_fault``: the part moved, then the action was reported failed); and a producing
station adds a part every ``produce_every`` seconds from ``produce_start`` unless it is full or at its
limit, before the actions that end at the same instant (docs/determinism.md's tie order).

A station's parts are steps at its transfers; between two, productions add to the count as their
instants pass, at most ``room`` of them (until the station is full or at its limit), which the page
counts itself, so a station producing every second for eight hours costs nothing until a part moves.
The rebuilt final counts are checked against ``summary.json``; a difference becomes a note in the page.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from vcran.core.stations import Station as CoreStation
from vcran.core.stations import StationMap
from vcran.view.model import Station, Steps
from vcran.view.poses import Poses

TRANSFERS = {"load": -1, "unload": +1}  # the station's change; the robot's is the opposite


def stations_of(fleet: dict[str, Any]) -> list[Station]:
    out = []
    for s in fleet.get("stations", []):
        every = float(s.get("produce_every", 0.0))
        start = s.get("produce_start")
        out.append(Station(str(s["id"]), (float(s["position"][0]), float(s["position"][1])), float(s.get("reach", 0.0)),
                           tuple((float(x), float(y)) for x, y in s.get("area", [])), int(s.get("capacity", 1_000_000)),
                           every, float(start) if start is not None else every, bool(s.get("charger"))))
    return out


def productions(station: Station, after: float, until: float) -> int:
    """Production instants in ``(after, until]`` (``after`` < 0: from the first)."""
    every = station.produce_every
    if every <= 0 or until < station.produce_start:
        return 0
    last = math.floor((until - station.produce_start) / every)
    first = 0 if after < station.produce_start else math.floor((after - station.produce_start) / every) + 1
    return max(0, last - first + 1)


def transfers(robots: list[str], fleet: dict[str, Any], events: list[dict[str, Any]],
              actions: dict[tuple[str, str], str], poses: Poses, end: float,
              summary: dict[str, Any] | None) -> tuple[Steps, Steps, np.ndarray, list[str]]:
    """Robots' loads, stations' parts (with each step's production room) and notes on any disagreement."""
    index = {rid: i for i, rid in enumerate(robots)}
    configs = fleet.get("robots", [])
    carrying = [int(c.get("carrying", 0)) for c in configs] + [0] * (len(robots) - len(configs))
    stations = stations_of(fleet)
    limits = [int(s.get("produce_limit", 0)) for s in fleet.get("stations", [])]
    lookup = StationMap([CoreStation(s.id, s.position[0], s.position[1], s.reach, area=s.area) for s in stations])
    where = {id(core): k for k, core in enumerate(lookup.stations)}
    faulted = {(e["robot"], e.get("action"), e["t"]) for e in events
               if e["event"] == "failed" and e.get("code") == "action_fault"}
    loads: list[list[tuple[float, int]]] = [[] for _ in robots]
    moves: list[list[tuple[float, int]]] = [[] for _ in stations]
    for e in events:
        i = index.get(e["robot"])
        if i is None or e["event"] != "action_finished":
            continue
        change = TRANSFERS.get(actions.get((e["robot"], str(e.get("action"))), ""))
        if change is None or not (e.get("ok") or (e["robot"], e.get("action"), e["t"]) in faulted):
            continue
        t = float(e["t"])
        x, y, _ = poses.pose(i, t)
        station = lookup.nearest_in_reach(x, y)
        if station is None:
            continue
        carrying[i] -= change
        loads[i].append((t, carrying[i]))
        moves[where[id(station)]].append((t, change))
    parts: list[list[tuple[float, int]]] = []
    rooms: list[int] = []
    finals: list[tuple[int, int]] = []
    for s, config, limit, changes in zip(stations, fleet.get("stations", []), limits, moves):
        count, produced, since = int(config.get("parts", 0)), 0, -1.0
        steps = []
        for t, change in [*changes, (end, 0)]:
            room = _room(s, count, produced, limit)
            made = min(productions(s, since, t), room)
            steps.append((since, count))
            rooms.append(room)
            count, produced, since = count + made + change, produced + made, t
        parts.append(steps)
        finals.append((count, produced))
    notes = _check(robots, stations, carrying, finals, summary)
    return Steps.build(loads, "int16"), Steps.build(parts, "int32"), np.array(rooms, dtype=np.int32), notes


def _room(station: Station, parts: int, produced: int, limit: int) -> int:
    """How many productions may still add a part: up to the station's capacity and its limit."""
    if station.produce_every <= 0:
        return 0
    room = max(0, station.capacity - parts)
    return min(room, max(0, limit - produced)) if limit else room


def _check(robots: list[str], stations: list[Station], carrying: list[int], finals: list[tuple[int, int]],
           summary: dict[str, Any] | None) -> list[str]:
    if summary is None:
        return []
    wrong = [rid for rid, n in zip(robots, carrying)
             if rid in summary.get("robots", {}) and summary["robots"][rid].get("carrying", n) != n]
    wrong += [s.id for s, (n, made) in zip(stations, finals)
              if s.id in summary.get("stations", {})
              and (summary["stations"][s.id].get("parts", n), summary["stations"][s.id].get("produced", made)) != (n, made)]
    if not wrong:
        return []
    return [f"the loads and parts rebuilt from the events differ from summary.json at the end for {', '.join(wrong[:5])}"
            + (f" and {len(wrong) - 5} more" if len(wrong) > 5 else "") + ": the page's counts may be off"]
