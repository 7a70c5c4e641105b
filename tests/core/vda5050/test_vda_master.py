"""The VDA 5050 master interface (docs/contract.md §11, issue 31 item 5): orders built from routes, the handle's stamping
and bookkeeping, the fleet a master is told of, and the hooks a loop calls.

Expected numbering is §6.6.2's, written out by hand: "the first node of an order receives a 0, the first
edge then gets the 1, the second node then gets the 2"; an update starts at its stitching node, the last
released node of the order so far, with that node's sequenceId ("Once a sequenceId is assigned, it does not
change with order updates"); orderUpdateId counts up.
"""

from __future__ import annotations

import random
import tomllib
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import orjson
import pytest

from vcran.core.jobs import JobBook
from vcran.core.vda5050 import codec, validation
from vcran.core.vda5050.builder import OrderLine, Stop, action
from vcran.core.vda5050.config import VehicleConfig
from vcran.core.vda5050.effects import Where
from vcran.core.vda5050.enums import ActionStatus, ConnectionState, Topic, Version
from vcran.core.vda5050.fleet import MasterFleet
from vcran.core.vda5050.header import Header
from vcran.core.vda5050.master import Master, MasterHandle
from vcran.core.vda5050.order import InstantActions, Order
from vcran.core.vda5050.state import State
from vcran.io.scenario_file import parse
from vcran.testing.vda5050.harness import Bench
from vcran.testing.vda5050.yard import Yard

# A line p (0, 0) - w (6, 0, a waiting node) - d (12, 0); stations P and D docked at p and d; one vehicle on p.
LINE = """
[simulation]
duration = 600.0
[simulation.action_durations]
load = 5.0
unload = 5.0
[[robots]]
id = "agv1"
vendor = "acme"
pose = [0.0, 0.0, 0.0]
max_velocity = 1.0
max_acceleration = 0.5
max_deceleration = 0.5
[[stations]]
id = "P"
position = [0.0, -1.0]
dock = "p"
parts = {parts}
[[stations]]
id = "D"
position = [12.0, -1.0]
dock = [12.0, 0.0, 1.5707963267948966]
[roadmap]
nodes = [{{ id = "p", x = 0.0, y = 0.0 }}, {{ id = "w", x = 6.0, y = 0.0, waiting = true }}, {{ id = "d", x = 12.0, y = 0.0 }}]
edges = [{{ from = "p", to = "w" }}, {{ from = "w", to = "d", speed = 0.5 }}]
{jobs}
"""

JOB = """
[[jobs]]
t = 1.0
id = "job_1"
pickup = "P"
dropoff = "D"
"""


def line(parts: int = 1, jobs: str = JOB) -> Any:
    return parse(tomllib.loads(LINE.format(parts=parts, jobs=jobs)), "<line>")


class Handle(MasterHandle):
    """The handle's three primitives, recorded: what a loop would send, at a time the test sets."""

    def __init__(self, fleet: MasterFleet, events: list[dict[str, Any]] | None = None) -> None:
        log = (lambda t, robot, event, fields: events.append({"t": t, "event": event, **fields})) if events is not None \
            else (lambda *_: None)
        super().__init__(fleet, JobBook(log), random.Random(0))
        self.t = 0.0
        self.sent: list[tuple[str, Topic, Order | InstantActions]] = []

    @property
    def now(self) -> float:
        return self.t

    def call_at(self, when: float, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
        raise AssertionError("no timers here")

    def _publish(self, serial: str, topic: Topic, message: Order | InstantActions) -> None:
        self.sent.append((serial, topic, message))


def compact(order: Order) -> list[str]:
    """Nodes and edges in sequence order: ``id`` + sequenceId, ``?`` marking the horizon (released false)."""
    parts = [(n.sequence_id, f"{n.node_id}{n.sequence_id}{'' if n.released else '?'}") for n in order.nodes]
    parts += [(e.sequence_id, f"{e.edge_id}{e.sequence_id}{'' if e.released else '?'}") for e in order.edges]
    return [text for _, text in sorted(parts)]


def test_a_new_order_numbers_nodes_and_edges_and_splits_base_and_horizon() -> None:
    """§6.6.2: sequenceIds 0, 1, 2 ... node, edge, node; the first ``base`` nodes and the edges between them
    released; the stations' actions at the last node; the edge into d carries its speed limit (0.5 m/s) and d
    the dock's heading (pi/2)."""
    fleet = MasterFleet.of(line())
    handle = Handle(fleet)
    pick = action("pick", "a1", "HARD", stationName="D")
    order = handle.order("agv1", ["p", "w", "d"], base=2, actions=[pick])
    assert compact(order) == ["p0", "p-w1", "w2", "w-d3?", "d4?"]
    assert order.order_id == "order_1" and order.order_update_id == 0
    assert order.nodes[2].actions == (pick,) and order.nodes[0].actions == order.nodes[1].actions == ()
    assert [e.max_speed for e in order.edges] == [None, 0.5]
    assert order.nodes[2].node_position is not None and order.nodes[2].node_position.theta == pytest.approx(1.5707963267948966)
    assert order.nodes[0].node_position is not None and order.nodes[0].node_position.map_id == "map"
    assert handle.sent == [("agv1", Topic.ORDER, order)]


def test_an_update_stitches_at_the_decision_point_and_numbers_on() -> None:
    """§6.6.2, Figures 5 and 6: the update repeats the last released node (w, 2) as its first node and goes
    on with 3, 4; orderUpdateId 1, then 2. An update releasing nothing more keeps the decision point."""
    handle = Handle(MasterFleet.of(line()))
    handle.order("agv1", ["p", "w", "d"], base=2, order_id="o")
    update = handle.extend("agv1", ["d"])
    assert (update.order_id, update.order_update_id) == ("o", 1)
    assert compact(update) == ["w2", "w-d3", "d4"]
    assert update.nodes[0].released and update.nodes[0].actions == ()
    again = handle.extend("agv1", [Stop("e", 18.0, 0.0)], base=0)
    assert (again.order_update_id, compact(again)) == (2, ["d4", "d-e5?", "e6?"])
    assert handle.line("agv1").decision_sequence == 4


def test_the_vehicle_takes_the_orders_the_handle_builds() -> None:
    """The handle's numbering is the vehicle's: on the bench the order is accepted, w is driven to, and the
    update releasing d is accepted as an update and driven (Figure 8 (7): the first node is the decision
    point)."""
    handle = Handle(MasterFleet.of(line()))
    bench = Bench(VehicleConfig("acme", "agv1"))
    bench.order(handle.order("agv1", ["p", "w", "d"], base=2))
    assert bench.seen()["nodes"] == ["w2", "d4?"] and bench.seen()["errors"] == []
    bench.reach()
    assert bench.seen()["last"] == ("w", 2) and bench.last.new_base_request
    bench.order(handle.extend("agv1", ["d"]))
    assert bench.seen()["order"] == ("order_1", 1) and bench.seen()["nodes"] == ["d4"] and bench.seen()["driving"]


@pytest.mark.parametrize("version", list(Version))
def test_what_the_handle_sends_validates_against_the_official_schema(version: Version) -> None:
    """Every message vcran sends validates (docs/contract.md §11): the master's orders, updates and instant actions
    too, in the vehicle's version, stamped with its manufacturer, serial number and version."""
    config = VehicleConfig("acme", "agv1", version=version)
    handle = Handle(MasterFleet.of(line(), [config]))
    handle.order("agv1", ["p", "w", "d"], base=2, actions=[action("drop", "d1", "HARD", stationName="D")])
    handle.extend("agv1", ["d"])
    handle.instant("agv1", "startPause")
    for _, topic, message in handle.sent:
        doc = orjson.loads(codec.encode(message, version))
        assert validation.first_problem(validation.outbound(topic, version), doc) is None
        assert message.header.version == version.value
        assert (message.header.manufacturer, message.header.serial_number) == ("acme", "agv1")


def test_header_ids_count_per_topic_and_vehicle_and_timestamps_are_simulated_time() -> None:
    """§6.4: headerId "is incremented by 1 with each sent message" per topic; vcran's clock is simulated
    time on the 1970 calendar (docs/vda5050.md)."""
    handle = Handle(MasterFleet.of(line()))
    handle.t = 2.5
    handle.order("agv1", ["p"])
    handle.instant("agv1", "startPause")
    handle.order("agv1", ["p"])
    handle.instant("agv1", "stopPause")
    assert [(topic.value, m.header.header_id) for _, topic, m in handle.sent] == [
        ("order", 0), ("instantActions", 0), ("order", 1), ("instantActions", 1)]
    assert handle.sent[0][2].header.timestamp == "1970-01-01T00:00:02.50Z"
    instant = handle.sent[1][2]
    assert isinstance(instant, InstantActions)
    assert [(a.action_type, a.action_id, a.blocking_type.value) for a in instant.actions] == [
        ("startPause", "startPause_1", "NONE")]


def test_the_master_stamps_on_the_scenarios_calendar() -> None:
    """``[simulation] epoch`` is the calendar of the master's headers too (MasterFleet.of gives every vehicle
    the scenario's, as the simulation's vehicles have it): 2.5 s after 2026-01-01T00:00:00Z, by hand."""
    scenario = line()
    dated = replace(scenario, settings=replace(scenario.settings, epoch="2026-01-01T00:00:00Z"))
    handle = Handle(MasterFleet.of(dated))
    handle.t = 2.5
    handle.order("agv1", ["p"])
    assert handle.sent[0][2].header.timestamp == "2026-01-01T00:00:02.50Z"


def test_resend_sends_the_last_order_again_with_a_new_header() -> None:
    """QoS 0 (§6.2): a lost order goes again as it was, the same orderId and orderUpdateId (a vehicle that
    had it discards the copy, §6.6.4.3), under the next headerId."""
    handle = Handle(MasterFleet.of(line()))
    with pytest.raises(ValueError, match="was sent no order"):
        handle.resend("agv1")
    handle.order("agv1", ["p", "w", "d"], base=2)
    update = handle.extend("agv1", ["d"])
    again = handle.resend("agv1")
    assert (again.order_id, again.order_update_id, again.nodes, again.edges) == (
        update.order_id, update.order_update_id, update.nodes, update.edges)
    assert [m.header.header_id for _, _, m in handle.sent] == [0, 1, 2]


def test_an_order_for_a_job_is_recorded_as_its_work() -> None:
    """docs/contract.md §9: the job book records the order sent for a job (``job_assigned``, the order as its task)."""
    events: list[dict[str, Any]] = []
    scenario = line()
    handle = Handle(MasterFleet.of(scenario), events)
    job = scenario.jobs[0]
    handle._jobs.arrived(1.0, job)
    handle.t = 1.0
    handle.order("agv1", ["p"], order_id="job_1_pick", job=job)
    handle.t = 3.0
    handle.job_done("job_1")
    assert [(e["t"], e["event"], e.get("task")) for e in events] == [
        (1.0, "job_arrived", None), (1.0, "job_assigned", "job_1_pick"), (3.0, "job_completed", None)]


@pytest.mark.parametrize(("call", "message"), [
    (lambda h: h.order("agv1", []), "at least one node"),
    (lambda h: h.order("agv1", ["p", "w"], base=0), "base 0"),
    (lambda h: h.extend("agv1", ["d"]), "no order to update"),
    (lambda h: h.order("agv1", ["p", "d"]), "no edge from 'p' to 'd'"),
    (lambda h: h.order("agv1", ["p", "x"]), "no node 'x'"),
    (lambda h: h.order("agv1", "pwd"), "the string 'pwd'"),
    (lambda h: h.order("agv9", ["p"]), "no vehicle 'agv9'"),
])
def test_what_cannot_be_an_order_is_refused_before_anything_is_sent(call: Callable[[Handle], Any],
                                                                    message: str) -> None:
    handle = Handle(MasterFleet.of(line()))
    with pytest.raises((ValueError, KeyError, TypeError), match=message):
        call(handle)
    assert handle.sent == []


def test_a_new_order_needs_a_new_order_id() -> None:
    """§6.6.2: the same orderId is an update; the line refuses to send it as a new order."""
    lane = OrderLine()
    header = Header(0, "1970-01-01T00:00:00.00Z", "2.1.0", "acme", "agv1")
    lane.new(header, "o", [Stop("a", 0.0, 0.0)])
    with pytest.raises(ValueError, match="new orderId"):
        lane.new(header, "o", [Stop("a", 0.0, 0.0)])


def test_the_fleet_names_vehicles_by_serial_number_and_reads_the_layout() -> None:
    """Without vehicle configurations a robot's serial number is its id and its manufacturer its vendor;
    docks are roadmap nodes (a named one, or the node at the dock's position)."""
    fleet = MasterFleet.of(line())
    assert fleet.serials == ("agv1",)
    assert (fleet.vehicle("agv1").config.manufacturer, fleet.vehicle("agv1").robot.pose) == ("acme", (0.0, 0.0, 0.0))
    assert (fleet.dock_node("P"), fleet.dock_node("D")) == ("p", "d")
    assert fleet.node_at(6.03, 0.0, 0.05) == "w" and fleet.node_at(6.1, 0.0, 0.05) is None
    assert fleet.graph is not None and fleet.graph.route("p", "d") is not None
    fleet.settings.durations["load"] = 99.0  # a copy: the scenario's stays
    assert line().settings.durations["load"] == 5.0
    with pytest.raises(ValueError, match="2 vehicle configurations for 1 robots"):
        MasterFleet.of(line(), [VehicleConfig("a", "b"), VehicleConfig("a", "c")])


class Recorder(Master):
    topics = frozenset({"state", "connection", "factsheet"})

    def on_start(self) -> None:
        self.heard: list[tuple[float, str, str]] = [(self.handle.now, "start", ",".join(self.fleet.serials))]

    def on_connection(self, serial: str, connection: Any) -> None:
        self.heard.append((self.handle.now, "connection", connection.connection_state.value))

    def on_factsheet(self, serial: str, factsheet: Any) -> None:
        self.heard.append((self.handle.now, "factsheet", factsheet.type_specification.series_name))

    def on_state(self, serial: str, state: State) -> None:
        self.heard.append((self.handle.now, "state", state.order_id))

    def on_job(self, job: Any) -> None:
        self.heard.append((self.handle.now, "job", job.id))
        self.handle.order("agv1", ["p", "w"])


def test_the_hooks_hear_what_the_vehicles_publish_after_the_link_s_latency() -> None:
    """docs/contract.md §9's hooks, for VDA 5050: on_start first with fleet and handle set; then, 50 ms after the vehicle
    came up (the link's latency), its connection (ONLINE), factsheet and state (§6.14, §6.15: at start);
    the job at t = 1; the state of the accepted order 50 ms after the order reached the vehicle (1.05)."""
    master = Recorder()
    yard = Yard(line(), master)
    yard.run(1.2)
    assert master.heard == [(0.0, "start", "agv1"), (0.05, "connection", "ONLINE"), (0.05, "factsheet", "vcran"),
                            (0.05, "state", ""), (1.0, "job", "job_1"), (pytest.approx(1.1), "state", "order_1")]
    assert master.handle.connection("agv1") is ConnectionState.ONLINE
    assert master.handle.factsheet("agv1") is not None
    state = master.handle.state("agv1")
    assert state is not None and state.order_id == "order_1"


def test_a_master_hears_only_the_topics_it_lists_but_the_handle_keeps_them_all() -> None:
    class StatesOnly(Recorder):
        topics = frozenset({"state"})

    master = StatesOnly()
    Yard(line(jobs=""), master).run(0.1)
    assert [kind for _, kind, _ in master.heard] == ["start", "state"]
    assert master.handle.connection("agv1") is ConnectionState.ONLINE


def test_position_is_the_latest_published_else_the_start_pose() -> None:
    class Mover(Master):
        def on_start(self) -> None:
            self.handle.order("agv1", ["p", "w"])

    master = Mover()
    yard = Yard(line(jobs=""), master)
    assert master.handle.position("agv1") == (0.0, 0.0, 0.0) and master.handle.state("agv1") is None
    # p -> w, 6 m from rest to rest at 1 m/s and 0.5 m/s^2: 2 s up (1 m), 4 s at 1 m/s, 2 s down: 8 s, from 0.05
    yard.run(8.2)
    assert master.handle.position("agv1") == (6.0, 0.0, 0.0)
    assert master.handle.state("agv1").last_node_id == "w"  # type: ignore[union-attr]
    assert yard.bodies["agv1"].where() == Where(6.0, 0.0, 0.0, 6.0)


def test_a_failed_action_is_what_the_state_says() -> None:
    """The Yard's pick at an empty station fails (docs/contract.md §4) and the state says FAILED with actionFailed."""
    class Picker(Master):
        def on_start(self) -> None:
            self.handle.order("agv1", ["p"], actions=[action("pick", "pk", "HARD", stationName="P")])

    master = Picker()
    Yard(line(parts=0, jobs=""), master).run(5.2)
    state = master.handle.state("agv1")
    assert state is not None
    assert [(a.action_id, a.action_status) for a in state.action_states] == [("pk", ActionStatus.FAILED)]
    assert [e.error_type for e in state.errors] == ["actionFailed"]
