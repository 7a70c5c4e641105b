"""``vcran report`` on VDA 5050 runs (issue 31 item 8, docs/report.md "VDA 5050 runs", docs/contract.md §11):
orders are the unit of work, busy runs from an order accepted to its end, the state lane says IDLE / ORDER /
DRIVING / ACTION.

Every expected figure is derived by hand. The bundled ``vda5050`` (scenarios/vda5050.toml; its kinematics
derived in tests/sim/test_vda5050_glue.py, whose END_100/200/300 are imported): three orders accepted at
their script times 1, 20 and 45, each ending completed. :data:`MIXED` is written here: one vehicle at (0, 0)
facing +x, 1 m/s, 0.5 m/s^2, so a 6 m leg from rest to rest takes 8 s (2 s and 1 m speeding up, 2 s and
1 m slowing down, 4 m at 1 m/s); a pick takes 5 s (docs/contract.md §4's default load) and
one at a station without a part fails at its end, moving nothing.

- t = 1: order o1 (update 1), a (0, 0) -> b (6, 0), a HARD pick at b at the empty station: b at 9, the pick
  RUNNING 9..14, FAILED at 14; the order's last node passed and its actions final, it ends ``completed`` at
  14 (§6.6), with its own action FAILED: the report's *action failed*.
- t = 3: o1 again with orderUpdateId 0, older than 1: rejected (§6.6.4.3, orderUpdateError): *rejected*.
- t = 20: order o2, b (6, 0) -> c (12, 0) -> d (18, 0); t = 22: cancelOrder, the vehicle on the 6 m leg to c
  (8 s from 20): it stops on c at 28 and the order ends ``cancelled`` (§6.6.3): *cancelled*.
- The run stops at the first 1 s tick at which the vehicle is idle: 28. Busy 13 + 8 = 21 s of 28.
- Errors: the orderUpdateError and the actionFailed warnings (two ``error_raised``).
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import pytest

from tests.sim.test_vda5050_glue import END_100, END_200, END_300, ONE_VEHICLE
from vcran.cli import main
from vcran.report import read_run, write_report
from vcran.report.incidents import incidents
from vcran.report.kpi import kpis
from vcran.report.layout import corners_by_robot, path_pieces
from vcran.report.spans import Band, histories
from vcran.report.tables import csv_text

pytest.importorskip("matplotlib")

ORDER_NODE = ('{{ nodeId = "{0}", sequenceId = {1}, released = true, '
              'nodePosition = {{ x = {2}, y = 0.0, mapId = "map" }}, actions = [{3}] }}')
PICK = ('{ actionType = "pick", actionId = "o1_pick", blockingType = "HARD", '
        'actionParameters = [{ key = "stationName", value = "empty" }] }')


def order(t: float, order_id: str, update: int, nodes: list[tuple[str, float, str]]) -> str:
    node_rows = ",\n".join(ORDER_NODE.format(n, 2 * i, x, actions) for i, (n, x, actions) in enumerate(nodes))
    edge_rows = ",\n".join(
        f'{{ edgeId = "{a}-{b}", sequenceId = {2 * i + 1}, released = true, startNodeId = "{a}", endNodeId = "{b}", actions = [] }}'
        for i, ((a, _, _), (b, _, _)) in enumerate(zip(nodes, nodes[1:])))
    return (f'\n[[script]]\nt = {t}\nrobot = "agv"\nkind = "order"\nmessage.orderId = "{order_id}"\n'
            f"message.orderUpdateId = {update}\nmessage.nodes = [\n{node_rows}\n]\nmessage.edges = [\n{edge_rows}\n]\n")


MIXED = ONE_VEHICLE + """capacity = 1

[[stations]]
id = "empty"
position = [6.0, 1.0]
reach = 1.5
parts = 0
""" + order(1.0, "o1", 1, [("a", 0.0, ""), ("b", 6.0, PICK)]) + order(3.0, "o1", 0, [("a", 0.0, "")]) \
    + order(20.0, "o2", 0, [("b", 6.0, ""), ("c", 12.0, ""), ("d", 18.0, "")]) + """
[[script]]
t = 22.0
robot = "agv"
kind = "instantActions"
message = '{"actions": [{"actionType": "cancelOrder", "actionId": "cancel_1", "blockingType": "NONE"}]}'
"""


@pytest.fixture(scope="module")
def demo(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("vda") / "run"
    assert main(["run", "vda5050", "--out", str(out), "--quiet"]) == 0
    return out


@pytest.fixture(scope="module")
def mixed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("mixed")
    (folder / "mixed.toml").write_text(MIXED)
    assert main(["run", str(folder / "mixed.toml"), "--out", str(folder / "run"), "--quiet"]) == 0
    return folder / "run"


def test_orders_are_the_unit_of_work_of_the_demo(demo: Path) -> None:
    """The three orders completed, busy from each order accepted (1, 20, 45) to its end over the run's 62 s
    (the first tick after 61.71 at which the vehicle is idle), latency the mean of accepted -> ended; the
    part moved once; no rejection, no error; distance 2 + 2√2 + 8 + 6 m."""
    run = read_run(demo)
    assert (run.protocol, run.sim_time) == ("vda5050", 62.0)
    rows = {k.robot: k for k in kpis(run, histories(run))}
    busy = (END_100 - 1.0) + (END_200 - 20.0) + (END_300 - 45.0)
    for row in (rows["robot_1"], rows["fleet"]):
        assert (row.completed, row.rejected, row.parts_moved, row.errors) == (3, 0, 1, 0)
        assert all(n == 0 for n in row.cancelled.values())
        assert row.busy_share == pytest.approx(busy / 62.0)
        assert row.latency == pytest.approx(busy / 3)
        assert row.distance == pytest.approx(2 + 2 * math.sqrt(2) + 8 + 6)


def test_the_state_lane_and_the_order_spans_of_the_demo(demo: Path) -> None:
    """Each order drives from its acceptance until its last node (100 and 200 then stand HARD for their
    5 s pick and drop: ACTION), and the vehicle is IDLE between orders; each order's bar runs from its
    acceptance to its end (no queue: started = queued)."""
    run = read_run(demo)
    history = histories(run)["robot_1"]
    expected = [("IDLE", 0.0, 1.0), ("DRIVING", 1.0, END_100 - 5), ("ACTION", END_100 - 5, END_100),
                ("IDLE", END_100, 20.0), ("DRIVING", 20.0, END_200 - 5), ("ACTION", END_200 - 5, END_200),
                ("IDLE", END_200, 45.0), ("DRIVING", 45.0, END_300), ("IDLE", END_300, 62.0)]
    assert [b.state for b in history.bands] == [s for s, _, _ in expected]
    assert [(b.start, b.end) for b in history.bands] == [(pytest.approx(a), pytest.approx(b)) for _, a, b in expected]
    assert [(s.task, s.outcome) for s in history.tasks] == [("100", "completed"), ("200", "completed"), ("300", "completed")]
    assert [(s.queued, s.started, s.end) for s in history.tasks] == [
        (1.0, 1.0, pytest.approx(END_100)), (20.0, 20.0, pytest.approx(END_200)), (45.0, 45.0, pytest.approx(END_300))]


def test_the_layout_bends_where_the_vehicle_passed_a_node(demo: Path) -> None:
    """Order 100's path passes dock_1 (4, 2), reached at 11.40, between two 1 s samples: the published
    state's agvPosition puts the corner there; the path starts at home and bends at n1 (2, 0)."""
    run = read_run(demo)
    pieces = path_pieces(run, 0, histories(run)["robot_1"], corners_by_robot(run)["robot_1"])
    first = next(points for span, points in pieces if span is not None and span.task == "100")
    points = [tuple(p) for p in first.round(9)]
    assert points[0] == (0.0, 0.0) and (2.0, 0.0) in points and points[-1] == (4.0, 2.0)


def test_rejected_cancelled_and_action_failed_orders(mixed: Path) -> None:
    """MIXED (module docstring): o1 completed with its pick FAILED is *action failed*, the stale o1 update
    *rejected*, o2 *cancelled*; nothing completed, so no latency; busy 21 of 28 s; two errors."""
    run = read_run(mixed)
    rows = {k.robot: k for k in kpis(run, histories(run))}
    for row in (rows["agv"], rows["fleet"]):
        assert (row.completed, row.rejected, row.latency, row.parts_moved, row.errors) == (0, 1, None, 0, 2)
        assert {r: n for r, n in row.cancelled.items() if n} == {"action_failed": 1, "cancelled": 1}
        assert row.busy_share == pytest.approx(21 / 28)
        assert row.distance == pytest.approx(12.0)
    history = histories(run)["agv"]
    assert [(s.task, s.queued, s.end, s.outcome) for s in history.tasks] == [
        ("o1", 1.0, 14.0, "action_failed"), ("o2", 20.0, 28.0, "cancelled")]
    # the cancelOrder runs from 22 while the vehicle drives on to c: the lane says DRIVING
    assert history.bands == [Band("IDLE", 0.0, 1.0), Band("DRIVING", 1.0, 9.0), Band("ACTION", 9.0, 14.0),
                             Band("IDLE", 14.0, 20.0), Band("DRIVING", 20.0, 28.0)]


def test_the_kpi_files_name_orders_columns(mixed: Path, tmp_path: Path) -> None:
    """kpi.csv of a VDA 5050 run: ``rejected`` where OPIL's has ``cancelled_timeout`` (a vehicle has no task
    timeout); the other columns keep OPIL's names for the analogous counts (docs/report.md)."""
    report = write_report(mixed, tmp_path / "report")
    assert sorted(f.name for f in report.files) == ["kpi.csv", "kpi.md", "layout.png", "timeline.png"]
    table = list(csv.DictReader(io.StringIO(csv_text(report.kpis))))
    assert list(table[0]) == ["robot", "completed", "rejected", "cancelled_cancelled", "cancelled_action_failed",
                              "distance_m", "busy_share", "idle_share", "mean_latency_s", "parts_moved", "errors"]
    assert [(r["robot"], r["rejected"], r["cancelled_cancelled"], r["mean_latency_s"], r["busy_share"])
            for r in table] == [("agv", "1", "1", "", "0.75"), ("fleet", "1", "1", "", "0.75")]
    assert (tmp_path / "report" / "kpi.csv").read_text() == csv_text(report.kpis)


def test_a_rejected_order_is_marked_on_the_state_lane(mixed: Path) -> None:
    """The stale update at t = 3 never becomes a bar: it is an incident of the timeline, at 3, on agv."""
    run = read_run(mixed)
    assert [(i.robot, i.t, i.kind) for i in incidents(run)] == [("agv", 3.0, "order_rejected")]


ROADMAP = """
[roadmap]
nodes = [{ id = "a", x = 0.0, y = 0.0 }, { id = "b", x = 6.0, y = 0.0 }, { id = "c", x = 12.0, y = 0.0 },
         { id = "d", x = 18.0, y = 0.0 }]
edges = [{ from = "a", to = "b" }, { from = "b", to = "c" }, { from = "c", to = "d" }]
"""


def test_the_layout_of_a_vda_run_draws_its_roadmap(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """docs/contract.md §12 on a VDA 5050 run: MIXED with the roadmap its orders' nodes lie on (the station
    docked at b); its three lanes and four nodes, from the file above, are drawn."""
    from tests.report.test_report_traffic import drawn_layout, roadmap_artists

    (tmp_path / "mixed.toml").write_text(MIXED.replace("parts = 0\n", 'parts = 0\ndock = "b"\n', 1) + ROADMAP)
    assert main(["run", str(tmp_path / "mixed.toml"), "--out", str(tmp_path / "run"), "--quiet"]) == 0
    drawn = roadmap_artists(drawn_layout(tmp_path / "run", monkeypatch))
    assert sorted(tuple(map(tuple, s)) for s in drawn["roadmap lane"].get_segments()) == [
        ((0.0, 0.0), (6.0, 0.0)), ((6.0, 0.0), (12.0, 0.0)), ((12.0, 0.0), (18.0, 0.0))]
    assert sorted(tuple(p) for p in drawn["roadmap node"].get_offsets()) == [(0.0, 0.0), (6.0, 0.0), (12.0, 0.0), (18.0, 0.0)]
