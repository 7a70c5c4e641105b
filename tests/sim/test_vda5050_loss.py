"""Message loss on VDA 5050's link in the closed loop (docs/contract.md §9, §11; VDA 5050 §6.2: order, instantActions,
state, factsheet and visualization travel at MQTT's QoS 0; issue 31 item 5): ``[link] loss``, its draws, the reference
master's resend, a replay of a lossy run, and the field's checks.

The draws, by hand (vcran/sim/link.py): every message draws once from ``random.Random(f"link:{seed}")`` when it is
sent, in the order sent, and is lost when the draw is below ``loss``; with no jitter nothing else draws. In the
run below the master sends nothing before the job: at t = 0 the vehicle publishes its factsheet and its first
state (draws 1-2; no visualization: MasterControl does not hear it, so the vehicles build none for it,
docs/vda5050.md "Your own master"); the job arrives at 0.5, and its pick order is **draw 3**. The seed is chosen
from the generator itself: its 3rd draw is below ``loss`` and none other of its first 1000 (the run sends fewer
than 200 messages: a state per event for some 30 s, and one at least every 30 s).

Instants: the vehicle starts at (0, 0) facing +x and drives 1 m/s with 0.5 m/s² up and down (a leg of d >= 2 m
from rest to rest: **d + 2 s**); the link takes **0.25 s** each way; a pick or drop takes **5 s**. Station ``a`` is
docked at (2, 0) with one part, ``b`` at (6, 0).
"""

from __future__ import annotations

import random
import tomllib
from dataclasses import replace

import pytest

import vcran
from tests.sim.test_vda5050_loop import seen
from tests.testing.test_vda_loop_properties import EMPTY_PICKUP
from vcran.cli import main
from vcran.core.scenario import LinkSettings
from vcran.io.scenario_file import ScenarioError, parse
from vcran.io.trace import records
from vcran.managers.vda5050 import MasterControl

LOSS = 0.001
#: tests/testing/test_vda_loop_properties.py's stations, ``a`` with one part, and the job at 0.5.
ONE_JOB = EMPTY_PICKUP.replace("parts = 0", "parts = 1").replace('t = 1.0\nid = "j1"', 't = 0.5\nid = "j1"')


def losing(only: set[int], loss: float, draws: int = 1000) -> int:
    """The first seed whose link generator loses exactly the draws numbered ``only`` (from 1) of its first ``draws``."""
    for seed in range(1_000_000):
        rng = random.Random(f"link:{seed}")
        if all((rng.random() < loss) == (k in only) for k in range(1, draws + 1)):
            return seed
    raise AssertionError("no such seed")


def one_job(seed: int, loss: float, duration: float = 100.0) -> vcran.Scenario:
    text = ONE_JOB.replace("[link]", f"[link]\nloss = {loss}").replace("duration = 300.0",
                                                                       f"duration = {duration}\nseed = {seed}")
    return parse(tomllib.loads(text), "<one job>")


def inbound(trace) -> list[tuple[float, str, str]]:
    """``(t, topic, orderId or actionType)`` of each message that reached the vehicle, as the trace records it."""
    out = []
    for _, r in records(trace, ("in",)):
        raw = r["raw"]
        out.append((r["t"], r["attr"], raw.get("orderId") or raw["actions"][0]["actionType"]))
    return out


def test_without_loss_the_job_takes_its_hand_derived_time(tmp_path):
    """The pick order goes out at 0.5 and reaches the vehicle at 0.75; the 2 m leg ends at 4.75, the pick at 9.75,
    heard at 10.0; the drop order reaches it at 10.25, the 4 m leg ends at 16.25, the drop at 21.25, heard at
    21.5: the job is done."""
    result = vcran.simulate(one_job(0, 0.0), manager=MasterControl(resend_after=5.0), out=tmp_path / "run")
    assert seen(result, "order_accepted", "job_completed") == [
        (0.75, "order_accepted", "j1_pick1"), (10.25, "order_accepted", "j1_drop1"), (21.5, "job_completed", "j1")]


def test_a_lost_order_is_sent_again_resend_after_later_and_the_job_ends_that_much_later(tmp_path):
    """Draw 3, the pick order sent at 0.5, is lost (module docstring): it never reaches the vehicle, so the trace
    does not have it. At 0.5 + 5 (resend_after) the master's latest state of the vehicle shows no order: it sends
    the order again, which reaches the vehicle at 5.75; everything of the run without loss happens 5 s later,
    and the job is done at 26.5. Nothing else is lost. The run replays and verifies (docs/contract.md §6): the
    trace holds what reached the vehicle."""
    seed = losing({3}, LOSS)
    result = vcran.simulate(one_job(seed, LOSS), manager=MasterControl(resend_after=5.0), out=tmp_path / "run")
    assert seen(result, "order_accepted", "job_completed") == [
        (5.75, "order_accepted", "j1_pick1"), (15.25, "order_accepted", "j1_drop1"), (26.5, "job_completed", "j1")]
    assert inbound(tmp_path / "run" / "trace.jsonl.zst") == [(5.75, "order", "j1_pick1"), (15.25, "order", "j1_drop1")]
    assert main(["replay", str(tmp_path / "run"), "--verify", "--quiet"]) == 0


def test_when_every_message_is_lost_nothing_reaches_either_side(tmp_path):
    """loss 0.999 and the first seed whose first 200 draws are all below it (some 82 % of seeds are): the run sends
    fewer than 100 messages in its 60 s (a few states, the order every 5 s, a stateRequest every 5 s after 35 s
    of quiet; no visualization, which the master does not hear). The vehicle never gets a message (no in record, no order accepted), the master
    never hears a state, and the job stays open to the end."""
    seed = losing(set(range(1, 201)), 0.999, 200)
    master = MasterControl(resend_after=5.0)
    result = vcran.simulate(one_job(seed, 0.999, duration=60.0), manager=master, out=tmp_path / "run")
    assert inbound(tmp_path / "run" / "trace.jsonl.zst") == []
    assert seen(result, "order_accepted") == [] and master.handle.state("agv1") is None
    assert result.summary["sim_time"] == 60.0 and result.job("j1").outcome == "open"


def test_vda5050_warehouse_with_a_lossy_link_completes_every_job():
    """``[link] loss = 0.05`` on vda5050-warehouse: one message in twenty lost, orders, instant actions and states
    alike; MasterControl resends what was lost and asks quiet vehicles for their state, and every job completes.
    The loss is real: more orders reach the vehicles than without loss (the resends)."""
    base = vcran.load_scenario("vda5050-warehouse")
    lossy = vcran.simulate(replace(base, link=replace(base.link, loss=0.05)))
    plain = vcran.simulate(base)
    assert len(lossy.jobs) == len(plain.jobs) > 200
    assert all(r.outcome == "completed" for r in lossy.jobs)
    accepted = [sum(e["event"] == "order_accepted" for e in r.events) for r in (lossy, plain)]
    resent = [sum(e["event"] == "order_discarded" for e in r.events) for r in (lossy, plain)]
    assert accepted[0] >= accepted[1] and resent[0] + accepted[0] > resent[1] + accepted[1]


@pytest.mark.parametrize(("value", "protocol", "message"), [
    ("1.0", "vda5050", "link: field 'loss': must be below 1 (a probability: 1 would lose every message), got 1.0"),
    ("-0.1", "vda5050", "link: field 'loss': must be at least 0.0, got -0.1"),
    ("0.02", "opil", "link: field 'loss': is VDA 5050's (MQTT's QoS 0 loses messages); Orion's link loses none"),
])
def test_a_bad_loss_is_refused_with_one_line_naming_the_field(value, protocol, message):
    text = ONE_JOB.replace("[link]", f"[link]\nloss = {value}")
    if protocol == "opil":
        text = text.replace('protocol = "vda5050"\n', "")
        text = "\n".join(line for line in text.splitlines()
                         if not line.startswith(("manufacturer", "serial_number")))
    with pytest.raises(ScenarioError) as info:
        parse(tomllib.loads(text), "<t>")
    assert message in str(info.value) and "\n" not in str(info.value)


def test_loss_is_written_only_when_there_is_some():
    """A run without loss writes the trace header it always wrote (byte-identical runs); a lossy one says so."""
    assert "loss" not in LinkSettings().as_dict()
    assert LinkSettings(loss=0.02).as_dict()["loss"] == 0.02
