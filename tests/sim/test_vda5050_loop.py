"""A VDA 5050 master in the closed loop, in simulated time (docs/contract.md §9, §11; issue 31 item 5;
vcran/sim/vda5050/loop.py): the link's latency each way, link_down (QoS 0), the hooks' tie order, a master's
invalid order and a master's exception, and a master of the wrong kind.

Every instant is derived by hand. The vehicle starts at (0, 0) facing +x and drives 1 m/s with 0.5 m/s² up and
down: a straight leg of d >= 2 m from rest to rest takes 2 s to speed up (1 m), d - 2 s at 1 m/s, 2 s to
slow down (1 m), **d + 2 s** in all. The link takes L = 0.25 s each way (exact in binary, so the sums are
too). A vehicle publishes its factsheet and a state when it comes up at t = 0 (§6.10, docs/vda5050.md), and
a state on every event.
"""

from __future__ import annotations

import tomllib
from dataclasses import replace
from typing import Any

import pytest

import vcran
from vcran.cli import main
from vcran.core.scenario import Job
from vcran.core.vda5050.builder import OrderLine, Stop
from vcran.core.vda5050.enums import Topic
from vcran.core.vda5050.factsheet import Factsheet
from vcran.core.vda5050.header import Header, timestamp
from vcran.core.vda5050.master import Master
from vcran.core.vda5050.state import State, Visualization
from vcran.io.scenario_file import parse
from vcran.managers.vda5050 import MasterControl

L = 0.25
HEAD = f"""
[simulation]
protocol = "vda5050"
duration = 100.0
until_idle = true
[link]
latency = {L}
[[robots]]
id = "robot_1"
manufacturer = "acme"
serial_number = "agv1"
pose = [0.0, 0.0, 0.0]
max_velocity = 1.0
max_acceleration = 0.5
max_deceleration = 0.5
"""


#: One job at t = 1 (the master below drives no station: a pick and drop are not what is timed here).
JOB = """
[[jobs]]
t = 1.0
id = "j1"
pickup = "a"
dropoff = "b"
[[stations]]
id = "a"
position = [0.0, 1.0]
[[stations]]
id = "b"
position = [0.0, -1.0]
"""


def scenario(extra: str = "") -> vcran.Scenario:
    return parse(tomllib.loads(HEAD + extra), "<test>")


def seen(result: vcran.Result, *kinds: str) -> list[tuple[float, str, Any]]:
    """``(t, event, the field that says most)`` of the run's events of these kinds."""
    key = {"order_accepted": "order_id", "node_traversed": "node_id", "order_ended": "how", "message_lost": "message",
           "job_arrived": "job", "job_assigned": "task", "job_completed": "job", "order_rejected": "order_id"}
    return [(e["t"], e["event"], e[key[e["event"]]]) for e in result.events if e["event"] in kinds]


class Heard(Master):
    """Records what reaches it: ``(now, hook, serial, what)``."""

    topics = frozenset({"state", "factsheet"})

    def __init__(self) -> None:
        self.heard: list[tuple[float, str, str, Any]] = []

    def on_state(self, serial: str, state: State) -> None:
        self.heard.append((self.handle.now, "state", serial, (state.order_id, state.last_node_id)))

    def on_factsheet(self, serial: str, factsheet: Factsheet) -> None:
        self.heard.append((self.handle.now, "factsheet", serial, None))

    def states(self) -> list[tuple[float, Any]]:
        return [(t, what) for t, hook, _, what in self.heard if hook == "state"]


class OneJob(Heard):
    """Sends the job's vehicle an order 2 m along +x and reports the job done when a state shows it ended."""

    def on_job(self, job: Job) -> None:
        self.job = job
        self.handle.order("agv1", [Stop("n0", 0.0, 0.0), Stop("n1", 2.0, 0.0)], order_id="o1", job=job)

    def on_state(self, serial: str, state: State) -> None:
        super().on_state(serial, state)
        if state.order_id == "o1" and not state.node_states and not state.driving:
            self.handle.job_done(self.job)


def test_the_order_arrives_a_latency_after_the_job_and_each_state_a_latency_after_it_was_published():
    """The job reaches the master at 1.0, the order the vehicle at 1.0 + L = 1.25 (accepted there, n0 where it
    stands); the 2 m leg ends at 1.25 + 4 = 5.25 (n1, the order completed). The states published at 0 (start),
    1.25 (accepted) and 5.25 (completed) reach the master L later: 0.25, 1.5, 5.5, where it reports the job
    done: a lead time of 4.5 s."""
    master = OneJob()
    result = vcran.simulate(scenario(JOB), manager=master)
    assert seen(result, "job_arrived", "job_assigned", "order_accepted", "node_traversed", "order_ended",
                "job_completed") == [
        (1.0, "job_arrived", "j1"), (1.0, "job_assigned", "o1"),
        (1.25, "order_accepted", "o1"), (1.25, "node_traversed", "n0"),
        (5.25, "node_traversed", "n1"), (5.25, "order_ended", "completed"),
        (5.5, "job_completed", "j1")]
    assert master.heard[:2] == [(0.25, "factsheet", "agv1", None), (0.25, "state", "agv1", ("", ""))]
    assert sorted({t for t, _ in master.states()}) == [0.25, 1.5, 5.5]
    assert master.states()[-1] == (5.5, ("o1", "n1"))
    assert result.job("j1").lead_time == 4.5
    assert result.summary["jobs"]["completed"] == 1 and result.summary["robots"]["robot_1"]["completed"] == ["o1"]


class Watching(OneJob):
    """:class:`OneJob`, reading ``handle.position("agv1")`` at the times :attr:`LOOKS` (timers run after the
    messages of their instant: docs/determinism.md)."""

    LOOKS = (0.1, 1.4, 1.5, 2.3, 3.0, 5.4, 5.5)

    def on_start(self) -> None:
        self.looked: dict[float, tuple[float, float, float]] = {}
        for t in self.LOOKS:
            self.handle.call_at(t, lambda t=t: self.looked.__setitem__(t, self.handle.position("agv1")))


def test_a_master_that_does_not_hear_visualization_receives_none_and_its_position_follows_the_states():
    """docs/vda5050.md, "Your own master": a master hears what its ``topics`` list, as live. Without
    ``visualization`` none reaches it, and ``position`` is the pose of the latest state that did: the states
    of 0 (start, at home), 1.25 (order accepted, n0 where it stands: still home) and 5.25 (n1, (2, 0))
    arrive at 0.25, 1.5 and 5.5. Before 0.25 no state: the start pose. Mid-leg (2.3, 3.0, 5.4) the vehicle
    is under way (1.25 s in at 2.5, test above), but the master knows the pose at the last state: home.
    A visualization (one a second) would have shown it moving."""
    master = Watching()
    vcran.simulate(scenario(JOB), manager=master)
    assert not master.hears(Topic.VISUALIZATION)
    assert not any(topic is Topic.VISUALIZATION for _, topic in master.handle._latest)  # none reached it
    home, n1 = (0.0, 0.0, 0.0), (2.0, 0.0, 0.0)
    assert master.looked == {0.1: home, 1.4: home, 1.5: home, 2.3: home, 3.0: home, 5.4: home, 5.5: n1}


class WatchingAll(Watching):
    """:class:`Watching` that hears ``visualization`` too, and records when each arrives and what it shows."""

    topics = frozenset({"state", "factsheet", "visualization"})

    def on_start(self) -> None:
        super().on_start()
        self.shown: list[tuple[float, str, float, float]] = []

    def on_visualization(self, serial: str, visualization: Visualization) -> None:
        p, v = visualization.agv_position, visualization.velocity
        assert p is not None and v is not None
        self.shown.append((self.handle.now, visualization.header.timestamp, p.x, v.vx))


def test_a_master_that_hears_visualization_receives_one_every_telemetry_period_a_latency_after_it():
    """With ``visualization`` in its ``topics`` the master receives the vehicle's every telemetry period (1 s,
    the default), published at k = 0, 1, 2 ... and arriving at k + L. The 2 m leg from rest at 1.25 (test
    above): 2 s at +0.5 m/s² to 1 m/s (1 m), then 2 s at -0.5 m/s² (1 m). At 2 (0.75 s in) x = 0.25 * 0.75² =
    0.140625, vx = 0.375; at 3 (1.75 s in) x = 0.25 * 1.75² = 0.765625, vx = 0.875; at 4 (0.75 s slowing down)
    x = 1 + 0.75 - 0.25 * 0.75² = 1.609375, vx = 0.625; at 5 (1.75 s slowing down) x = 1 + 1.75 - 0.25 * 1.75²
    = 1.984375, vx = 0.125. The job is done at 5.5 (its last state) and the run ends at the next tick, 6, so the
    visualization published there never arrives. ``position`` reads the newer of the state and the
    visualization: at 2.3 and 3.0 the visualization published at 2 (x = 0.140625); at 5.4 the one of 5;
    at 5.5 the state of 5.25 (n1)."""
    master = WatchingAll()
    result = vcran.simulate(scenario(JOB), manager=master)
    assert result.summary["sim_time"] == 6.0
    assert master.shown == [(k + L, f"1970-01-01T00:00:0{k}.00Z", x, vx) for k, x, vx in (
        (0, 0.0, 0.0), (1, 0.0, 0.0), (2, 0.140625, 0.375), (3, 0.765625, 0.875), (4, 1.609375, 0.625),
        (5, 1.984375, 0.125))]
    home = (0.0, 0.0, 0.0)
    assert master.looked == {0.1: home, 1.4: home, 1.5: home, 2.3: (0.140625, 0.0, 0.0), 3.0: (0.140625, 0.0, 0.0),
                             5.4: (1.984375, 0.0, 0.0), 5.5: (2.0, 0.0, 0.0)}


class CancelWhileDown(Heard):
    """At the start, an order 0 -> n1 (4, 0) -> n2 (10, 0), all released (the base); at t = 3 a cancelOrder."""

    def on_start(self) -> None:
        self.handle.order("agv1", [Stop("n0", 0.0, 0.0), Stop("n1", 4.0, 0.0), Stop("n2", 10.0, 0.0)], order_id="o1")
        self.handle.call_at(3.0, self.handle.instant, "agv1", "cancelOrder")


def test_while_the_link_is_down_the_vehicle_goes_on_with_its_base_and_what_the_master_sends_is_lost(tmp_path):
    """docs/contract.md §4, §9, §11: the link is down from 2 to 7. The order arrives at L = 0.25; the 4 m leg to n1 ends
    at 0.25 + 6 = 6.25, the 6 m leg to n2 at 6.25 + 8 = 14.25: the vehicle drives its base as if nothing
    happened. The cancelOrder sent at 3 reaches the vehicle at 3.25, while its link is down: lost (QoS 0,
    §6.2). The state of 6.25 (n1) waits for the link: published at 7, heard at 7.25; nothing is heard
    between 2 + L and then. The run's replay cuts the vehicle's link too, so the cancelOrder recorded as it
    reached the vehicle is lost again and the replay verifies (docs/contract.md §6)."""
    master = CancelWhileDown()
    result = vcran.simulate(scenario('[[faults]]\nt = 2.0\nrobot = "robot_1"\nkind = "link_down"\nduration = 5.0\n'),
                            manager=master, out=tmp_path / "run")
    assert seen(result, "order_accepted", "node_traversed", "order_ended", "message_lost") == [
        (0.25, "order_accepted", "o1"), (0.25, "node_traversed", "n0"),
        (3.25, "message_lost", "instantActions lost: the robot's link is down [§4, VDA 5050 §6.2]"),
        (6.25, "node_traversed", "n1"), (14.25, "node_traversed", "n2"), (14.25, "order_ended", "completed")]
    times = [t for t, _ in master.states()]
    assert not [t for t in times if 2.0 + L < t < 7.0 + L]
    assert [what for t, what in master.states() if t == 7.25] == [("o1", "n1")]
    assert master.states()[-1] == (14.5, ("o1", "n2"))
    assert result.summary["robots"]["robot_1"]["completed"] == ["o1"]
    assert main(["replay", str(tmp_path / "run"), "--verify", "--quiet"]) == 0


class TieOrder(Heard):
    """At 0.25 a state and the factsheet (published at 0) reach it, job j1 arrives, and its timer falls due."""

    def on_start(self) -> None:
        self.handle.call_at(L, self.tick)

    def on_job(self, job: Job) -> None:
        self.heard.append((self.handle.now, "job", "", job.id))
        self.handle.job_done(job)

    def tick(self) -> None:
        self.heard.append((self.handle.now, "timer", "", None))


def test_at_one_instant_the_master_hears_updates_then_jobs_then_timers():
    """vcran/sim/timing.py's order (docs/determinism.md): the vehicles' publications first, then jobs, then timers."""
    master = TieOrder()
    vcran.simulate(scenario(JOB.replace("t = 1.0", f"t = {L}")), manager=master)
    assert [(t, hook) for t, hook, _, _ in master.heard] == [
        (L, "factsheet"), (L, "state"), (L, "job"), (L, "timer")]


class Invalid(Heard):
    """Sends an order whose first node has sequenceId -1, which the schema refuses (minimum 0)."""

    def on_start(self) -> None:
        order = OrderLine().new(Header(0, timestamp(0.0), "2.1.0", "acme", "agv1"), "bad",
                                [Stop("n0", 0.0, 0.0), Stop("n1", 2.0, 0.0)])
        self.handle.send("agv1", replace(order, nodes=(replace(order.nodes[0], sequence_id=-1), *order.nodes[1:])))
        self.errors: list[tuple[float, str, str]] = []

    def on_state(self, serial: str, state: State) -> None:
        super().on_state(serial, state)
        self.errors += [(self.handle.now, e.error_type, e.error_description or "") for e in state.errors]


def test_a_masters_invalid_order_crosses_the_wire_and_the_vehicle_refuses_it_with_a_validation_error():
    """§6.6.4.1: what the master sends is encoded, sent and validated as on a broker. An order with
    sequenceId -1 on its first node is refused at L = 0.25 (order_rejected; nothing driven) and the state
    published there, heard at 0.5, carries a validationError naming the field; the run goes on and ends."""
    master = Invalid()
    result = vcran.simulate(scenario(), manager=master)
    assert seen(result, "order_rejected", "order_accepted") == [(0.25, "order_rejected", "bad")]
    assert [(t, kind) for t, kind, _ in master.errors][:1] == [(0.5, "validationError")]
    assert "sequenceId" in master.errors[0][2]
    assert result.summary["robots"]["robot_1"]["distance"] == 0.0


class Raising(Heard):
    def on_state(self, serial: str, state: State) -> None:
        raise RuntimeError("my bug")


def test_a_master_raising_in_a_hook_ends_the_run_with_a_note_naming_the_hook():
    """docs/contract.md §9: the first state (published at 0) reaches on_state at L = 0.25, which raises."""
    with pytest.raises(RuntimeError, match="my bug") as err:
        vcran.simulate(scenario(), manager=Raising())
    assert "in fleet manager Raising: on_state at t=0.25" in err.value.__notes__


@pytest.mark.parametrize("name, manager, message", [
    ("vda5050-warehouse", "vcran.managers:Dispatcher",
     "fleet manager vcran.managers.dispatcher:Dispatcher is an OPIL fleet manager (vcran.FleetManager); this "
     "scenario's robots speak VDA 5050 ([simulation] protocol = 'vda5050'): its manager is a "
     "vcran.core.vda5050.master.Master subclass"),
    ("warehouse", MasterControl,
     "fleet manager vcran.managers.vda5050:MasterControl is a VDA 5050 master (vcran.core.vda5050.master.Master); "
     "this scenario's robots speak OPIL ([simulation] protocol = 'opil'): its manager is a vcran.FleetManager "
     "subclass"),
    ("warehouse", MasterControl(), "is a VDA 5050 master"),
    ("vda5050-warehouse", "json:dumps", "'json:dumps' is not a vcran.core.vda5050.master.Master subclass"),
])
def test_a_manager_of_the_other_protocols_kind_is_a_manager_error_naming_both(tmp_path, name, manager, message):
    with pytest.raises(vcran.ManagerError) as err:
        vcran.simulate(name, manager=manager, out=tmp_path / "out")
    assert message in str(err.value)
    assert not (tmp_path / "out").exists()


def test_a_master_instance_subclass_or_path_runs_a_vda5050_scenario():
    """``manager`` as an instance, a subclass or ``module:Class`` (docs/library.md): the same run each time."""
    sc = scenario(JOB)
    runs = [vcran.simulate(sc, manager=m) for m in (OneJob(), OneJob, f"{__name__}:OneJob")]
    assert [r.summary for r in runs[1:]] == [runs[0].summary, runs[0].summary]
    assert runs[0].jobs[0].lead_time == 4.5


def test_loop_summary_counts_jobs_and_the_vehicles_busy_time():
    """docs/contract.md §9's summary for a VDA 5050 run: the job done, and robot_1 busy from the order accepted (1.25) to
    its end (5.25): 4 s of the run's 6.0 s (the first idle tick after the job was reported done at 5.5)."""
    master = OneJob()
    result = vcran.simulate(scenario(JOB), manager=master)
    assert result.summary["sim_time"] == 6.0
    assert result.summary["utilisation"]["robots"]["robot_1"] == 4.0 / 6.0
    assert result.summary["jobs"]["arrived"] == result.summary["jobs"]["completed"] == 1
    assert [(r.id, r.outcome, r.robot, r.tasks) for r in result.jobs] == [("j1", "completed", "robot_1", ("o1",))]

