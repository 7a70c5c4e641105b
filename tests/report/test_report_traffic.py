"""docs/contract.md §12 in `vcran report` and `vcran sweep`: blocks, blocked time and deadlocks, counted from the events
(vcran.report.traffic) and from the summary's ``traffic`` section (vcran.sweep.worker), and shown only for
runs whose robots had safety fields."""

from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from vcran.cli import main
from vcran.io.scenario_file import load
from vcran.report.folder import RobotResult, RobotSpec, Run, read_run
from vcran.report.incidents import incidents
from vcran.report.kpi import kpis
from vcran.report.spans import histories
from vcran.report.tables import csv_text, markdown
from vcran.report.traffic import Blocking, blocking
from vcran.sweep import worker
from vcran.sweep.table import columns

if TYPE_CHECKING:
    from matplotlib.figure import Figure

SQUARE = ((0.5, 0.5), (-0.5, 0.5), (-0.5, -0.5), (0.5, -0.5))


def event(t: float, robot: str, name: str, **fields: object) -> dict[str, object]:
    return {"t": t, "robot": robot, "event": name, **fields}


# The corridor of docs/robots.md with on_deadlock = "cancel" for A only (say): both blocked at 9, the cycle at
# 11; A is unblocked at 11 (its task cancelled), B stays blocked to the end at 120. C, parked behind B, is
# blocked by it from 100 and reported past a bound of 10 s at 110 (kind bound, naming B).
CORRIDOR = [
    event(9.0, "A", "blocked", other="B", x=8.0, y=0.0), event(9.0, "B", "blocked", other="A", x=12.0, y=0.0),
    event(11.0, "A", "deadlock", kind="cycle", other="B", duration=2.0),
    event(11.0, "A", "unblocked", duration=2.0),
    event(100.0, "C", "blocked", other="B", x=15.0, y=0.0),
    event(110.0, "C", "deadlock", kind="bound", other="B", duration=10.0),
]


def run(events: list[dict[str, object]], fields: bool = True) -> Run:
    ids = ("A", "B", "C")
    return Run(Path("."), "corridor", 0, 120.0, 0, tuple(RobotSpec(r, (0.0, 0.0, 0.0), SQUARE) for r in ids), (),
               {r: RobotResult(0.0, 0, 0, (0.0, 0.0, 0.0)) for r in ids}, events, np.zeros((0, 0)), fields=fields)


def test_s12_blocks_blocked_time_and_deadlocks_per_robot() -> None:
    """A: blocked 9 -> 11 (2 s), in the cycle; B: 9 -> the end at 120 (111 s), in the cycle (named by A's
    event); C: 100 -> 120 (20 s), its own bound deadlock (B, which it waited for, is not deadlocked by it)."""
    assert blocking(run(CORRIDOR)) == {"A": Blocking(1, 2.0, 1), "B": Blocking(1, 111.0, 1), "C": Blocking(1, 20.0, 1)}


def test_s12_the_fleet_row_counts_each_deadlock_once() -> None:
    r = run(CORRIDOR)
    rows = {k.robot: k for k in kpis(r, histories(r))}
    assert (rows["fleet"].blocks, rows["fleet"].blocked_time, rows["fleet"].deadlocks) == (3, 133.0, 2)
    assert (rows["B"].blocks, rows["B"].blocked_time, rows["B"].deadlocks) == (1, 111.0, 1)


def test_s12_columns_appear_when_the_robots_had_fields() -> None:
    with_fields = run([])  # fields on, nothing blocked: zeros are worth showing
    header = next(csv.reader(io.StringIO(csv_text(kpis(with_fields, histories(with_fields))))))
    assert header[-4:] == ["cancelled_deadlock", "blocks", "blocked_s", "deadlocks"]
    assert "| blocked (s) |" in markdown(kpis(with_fields, histories(with_fields))).splitlines()[0].replace("  ", " ")
    without = run([], fields=False)
    rows = kpis(without, histories(without))
    assert all(k.blocks is None and k.blocked_time is None and k.deadlocks is None for k in rows)
    assert "blocks" not in next(csv.reader(io.StringIO(csv_text(rows))))


def test_s12_blocks_and_deadlocks_are_incidents_on_the_figures() -> None:
    marked = [(i.robot, i.t, i.kind, i.place) for i in incidents(run(CORRIDOR))]
    assert marked == [("A", 9.0, "blocked", (8.0, 0.0)), ("B", 9.0, "blocked", (12.0, 0.0)),
                      ("A", 11.0, "deadlock", None), ("C", 100.0, "blocked", (15.0, 0.0)),
                      ("C", 110.0, "deadlock", None)]


def summary(traffic: dict[str, object] | None) -> dict[str, object]:
    out: dict[str, object] = {
        "sim_time": 120.0, "errors": 0,
        "robots": {"A": {"completed": [], "cancelled": [{"task": "t1", "reason": "deadlock"}], "distance": 9.0,
                         "parts_moved": 0},
                   "B": {"completed": ["t2"], "cancelled": [], "distance": 9.0, "parts_moved": 0}},
    }
    if traffic is not None:
        out["traffic"] = traffic
    return out


def test_s12_sweep_rows_carry_the_summarys_traffic() -> None:
    row = worker.kpis(summary({"blocks": 2, "blocked_time": 113.0, "deadlocks": 1}))
    assert {k: row[k] for k in worker.TRAFFIC} == {"cancelled_deadlock": 1, "blocks": 2, "blocked_time": 113.0,
                                                   "deadlocks": 1}
    # the columns follow the KPIs every run has, in that order
    names = columns([row], ["run"])
    at = names.index("collisions")
    assert names[at + 1:at + 5] == list(worker.TRAFFIC)


def test_s12_sweep_rows_without_fields_keep_their_columns() -> None:
    """A run without fields has no traffic section: its row, and so a sweep's runs.csv, are as before."""
    row = worker.kpis(summary(None))
    assert not set(worker.TRAFFIC) & set(row) and tuple(row) == worker.KPIS
    assert "cancelled_deadlock" not in worker.KPIS


def test_s12_a_deadlock_cancel_is_a_reason_of_the_report() -> None:
    reason = "deadlock"  # on_deadlock = "cancel" (vcran.sim.opil.traffic)
    r = run([event(0.0, "A", "task_queued", task="t1"), event(0.0, "A", "state", **{"from": "WAITING", "to": "TASK"}),
             event(11.0, "A", "task_cancelled", task="t1", reason=reason),
             event(11.0, "A", "state", **{"from": "MOTION", "to": "WAITING"})])
    rows = {k.robot: k for k in kpis(r, histories(r))}
    assert rows["A"].cancelled[reason] == 1 and rows["fleet"].cancelled[reason] == 1


def drawn_layout(folder: Path, monkeypatch: pytest.MonkeyPatch) -> Figure:
    """The layout figure `vcran report` draws for ``folder``, caught before it is saved."""
    from vcran.report import layout

    caught: list[Figure] = []
    monkeypatch.setattr(layout, "save", lambda fig, path: caught.append(fig))
    r = read_run(folder)
    layout.draw_layout(r, histories(r), folder / "layout.png")
    (fig,) = caught
    return fig


def roadmap_artists(fig: Figure) -> dict[str, Any]:
    return {a.get_gid(): a for a in fig.axes[0].get_children() if (a.get_gid() or "").endswith(("lane", "node"))}


@pytest.mark.slow
def test_s12_the_layout_draws_the_warehouses_roadmap(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Issue 32 item 1, "Reports draw it": every edge of warehouse-traffic's roadmap, read from the scenario
    file (not from the run), is one segment of the drawn lanes, and every node one drawn point."""
    pytest.importorskip("matplotlib")
    folder = tmp_path / "run"
    assert main(["run", "warehouse-traffic", "--out", str(folder), "--quiet"]) == 0
    roadmap = load("warehouse-traffic").roadmap
    assert roadmap is not None
    at = {n.id: (n.x, n.y) for n in roadmap.nodes}
    drawn = roadmap_artists(drawn_layout(folder, monkeypatch))
    segments = [tuple(map(tuple, seg)) for name in ("roadmap lane", "one-way lane") if name in drawn
                for seg in drawn[name].get_segments()]
    assert sorted(segments) == sorted((at[e.start], at[e.end]) for e in roadmap.edges)
    points = [tuple(p) for name in ("roadmap node", "waiting node") if name in drawn for p in drawn[name].get_offsets()]
    assert sorted(points) == sorted(at.values())


def test_s12_a_layout_without_a_roadmap_draws_none(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A run whose scenario has no roadmap (the demo) gets no lane and no node on its layout."""
    pytest.importorskip("matplotlib")
    folder = tmp_path / "run"
    assert main(["run", "demo", "--out", str(folder), "--quiet"]) == 0
    assert load("demo").roadmap is None
    fig = drawn_layout(folder, monkeypatch)
    assert fig.axes[0].lines or fig.axes[0].collections  # the figure did draw (paths, stations)
    assert roadmap_artists(fig) == {}
