"""docs/contract.md §9's loop properties for a VDA 5050 master (§11; issue 31 item 5's fuzzing): a job's task is
an order, so the evidence for a failed job, a job waiting again, a robot idle and a protocol error are read
from the vehicles' order events (docs/vda5050.md, "In the closed loop"); ``vcran fuzz`` fuzzes a master.

Instants derived by hand: the vehicle starts at (0, 0) facing +x, drives 1 m/s with 0.5 m/s² up and down (a
2 m leg from rest to rest: 2 s up, 2 s down, **4 s**); the link takes **0.25 s** each way; a pick takes
**5 s**. Station ``a`` (docked at (2, 0)) holds no part, so every pick there FAILS (an ``actionFailed``
error naming the order; the order itself ends completed, §6.11).
"""

from __future__ import annotations

import tomllib

import pytest

import vcran
from tests.sim.test_vda5050_loop import HEAD, Invalid
from vcran.cli import main
from vcran.core.jobs import waiting_spans
from vcran.core.scenario import Job
from vcran.core.vda5050.builder import Stop
from vcran.core.vda5050.master import Master
from vcran.io.scenario_file import parse
from vcran.managers.vda5050 import MasterControl
from vcran.testing.loop import check_jobs_ended, check_no_idle_while_waiting, check_protocol, loop_problems
from vcran.testing.outcomes import check_failures_have_evidence

EMPTY_PICKUP = HEAD.replace("duration = 100.0", "duration = 300.0") + """
[simulation.action_durations]
load = 5.0
unload = 5.0
[[stations]]
id = "a"
position = [2.0, 1.0]
dock = [2.0, 0.0, 0.0]
parts = 0
[[stations]]
id = "b"
position = [6.0, 1.0]
dock = [6.0, 0.0, 0.0]
[[jobs]]
t = 1.0
id = "j1"
pickup = "a"
dropoff = "b"
"""


def empty_pickup() -> vcran.Scenario:
    return parse(tomllib.loads(EMPTY_PICKUP), "<empty pickup>")


def test_a_job_failed_after_failed_picks_has_evidence_and_waits_between_tries():
    """MasterControl (max_tries 2, retry_after 1): the order j1_pick1 goes out at 1.0 (job_assigned), reaches the
    vehicle at 1.25; the 2 m leg ends at 5.25, the pick fails at 10.25 (actionFailed naming j1_pick1), heard
    at 10.5; the retry after 1 s sends j1_pick2 at 11.5 from where the vehicle stands (on a's dock: a one-node
    order), which reaches it at 11.75 and fails at 16.75, heard at 17.0: the job is reported failed there.
    Evidence: both orders ended without success before 17.0. The job waited from its arrival (1.0) to the first
    order (1.0), again from the first order's failed pick (10.25) to the retry (11.5), and from the second's
    (16.75) to the report (17.0)."""
    result = vcran.simulate(empty_pickup(), manager=MasterControl(max_tries=2, retry_after=1.0))
    record = result.job("j1")
    assert (record.outcome, record.ended, record.tasks) == ("failed", pytest.approx(17.0), ("j1_pick1", "j1_pick2"))
    assert check_failures_have_evidence(result) == [] and check_protocol(result) == []
    spans = waiting_spans(result.events, result.summary["sim_time"])
    assert [(job, pytest.approx(a), pytest.approx(b)) for job, a, b in spans] == [
        ("j1", 1.0, 1.0), ("j1", 10.25, 11.5), ("j1", 16.75, 17.0)]
    assert loop_problems(result) == []


class Liar(Master):
    """Sends the job's vehicle an order to a's dock, and reports the job failed at once."""

    def on_job(self, job: Job) -> None:
        self.handle.order("agv1", [Stop("n0", 0.0, 0.0), Stop("n1", 2.0, 0.0)], order_id="o1", job=job)
        self.handle.job_failed(job, "action_failed")


def test_a_job_reported_failed_before_its_order_ended_has_no_evidence():
    """The order o1 is sent at 1.0 and ends (completed, no action) at 1.25 + 4 = 5.25; the job was reported
    failed at 1.0, when nothing had ended."""
    result = vcran.simulate(empty_pickup(), manager=Liar())
    assert check_failures_have_evidence(result) == [
        "job j1 reported failed (action_failed) at t=1 without evidence: none of its 1 task(s) (o1) had ended "
        "without success by then, and a robot could serve it"]


class Idle(Master):
    """Never sends anything."""


def test_a_master_that_never_sends_an_order_leaves_the_job_open_and_the_vehicle_idle():
    """The job arrives at 1.0 and stays open to the end (300 s: jobs open, the run never idles out); the
    vehicle has no order from 0 to 300, so it idles 299 s while j1 waits, more than the 60 s bound."""
    result = vcran.simulate(empty_pickup(), manager=Idle())
    assert result.summary["sim_time"] == 300.0
    assert check_jobs_ended(result) == [
        "job j1 (arrived t=1, a -> b) never ended: neither completed nor reported failed by t=300 (0 task(s) sent)"]
    assert check_no_idle_while_waiting(result) == [
        "robot_1 idle from t=1 to t=300 (299 s > 60 s) while job j1 waited (since t=1)"]


def test_an_order_the_vehicle_refuses_is_the_masters_protocol_error():
    """The order with sequenceId -1 (tests/sim/test_vda5050_loop.py) is refused at 0.25 (validationError)."""
    result = vcran.simulate(empty_pickup(), manager=Invalid())
    [problem] = check_protocol(result)
    assert problem.startswith("t=0.25 robot_1: order bad (update 0) refused, validationError: ")


def test_vcran_fuzz_fuzzes_a_vda5050_master(tmp_path, capsys):
    """``vcran fuzz`` on vda5050-warehouse fuzzes its master in the closed loop (workload, stock, link; a broker's
    link: no polling); a master that never sends an order breaks a property, and the saved scenario names it."""
    assert main(["fuzz", "vda5050-warehouse", "--examples", "3", "--jobs", "2"]) == 0
    assert ("vcran fuzz: vcran.managers.vda5050:MasterControl kept the loop properties on 3 examples of "
            "vda5050-warehouse") in capsys.readouterr().out
    save = tmp_path / "failing.toml"
    assert main(["fuzz", "vda5050-warehouse", "--manager", f"{__name__}:Idle", "--examples", "3", "--jobs", "2",
                 "--save", str(save)]) == 1
    failing = vcran.load_scenario(save)
    assert failing.settings.protocol == "vda5050" and failing.manager.path == f"{__name__}:Idle"
    assert failing.link.inbound == "subscription"
    assert "never ended" in capsys.readouterr().err


def test_a_vehicle_on_its_way_is_not_idle_while_the_next_job_waits():
    """Two jobs at 1.0 from a (2 parts) to c, docked 70 m further along +x, for one vehicle: j1's pick order
    reaches it at 1.25, the 2 m leg and the pick end at 10.25 (heard 10.5); the drop order reaches it at 10.75,
    the 70 m leg takes 2 + 68 + 2 = 72 s (to 82.75), the drop 5 s (to 87.75), heard at 88.0: only then does j2
    get the vehicle. j2 waited 87 s, more than the 60 s bound, but the vehicle was never idle more than the
    link's round trip meanwhile (it executed an order): no violation."""
    text = EMPTY_PICKUP.replace("parts = 0", "parts = 2").replace(
        'id = "b"\nposition = [6.0, 1.0]\ndock = [6.0, 0.0, 0.0]', 'id = "c"\nposition = [72.0, 1.0]\ndock = [72.0, 0.0, 0.0]')
    text = text.replace('dropoff = "b"', 'dropoff = "c"') + '[[jobs]]\nt = 1.0\nid = "j2"\npickup = "a"\ndropoff = "c"\n'
    result = vcran.simulate(parse(tomllib.loads(text), "<two jobs>"), manager=MasterControl())
    assert [r.outcome for r in result.jobs] == ["completed", "completed"]
    spans = waiting_spans(result.events, result.summary["sim_time"])
    assert [(job, pytest.approx(a), pytest.approx(b)) for job, a, b in spans] == [("j1", 1.0, 1.0), ("j2", 1.0, 88.0)]
    assert check_no_idle_while_waiting(result) == []
