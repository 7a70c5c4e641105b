"""docs/contract.md §7 on the fleet manager's side (issue 30 item 2): ``vcran manage`` keeps its link to Orion as
``vcran live`` does, because it is the same link (transports/orion/link.py). Its subscriptions are
re-created when Orion loses them, nothing Orion holds is lost across a gap, its writes back off on 4xx
and 5xx without flooding Orion and each reaches Orion in the end, in order.

End to end with real processes on 127.0.0.1 (as tests/transports/test_manage.py), and in process against
vcran's broker or httpx.MockTransport (the fleet side's helpers, tests/transports/test_orion_transport.py),
where the test decides when Orion fails. Every wait is for a condition, with a generous deadline.
"""

from __future__ import annotations

import json
import logging
import time
from typing import Any

import httpx
import pytest

from tests.transports.test_live import broker_process, free_port, stop, vcran, wait_until  # noqa: F401 - the fixture
from tests.transports.test_manage import ROBOTS, WAREHOUSE, CallNow, put, updates, warehouse_live
from tests.transports.test_orion_transport import RETRY_AFTER, FakeOrion, RefusingOrion, most_requests
from transports.orion.client import OrionClient
from transports.orion.link import LinkOptions
from transports.orion.manage import OrionManagerLink
from vcran.broker import start_broker
from vcran.core.opil.build import cancel, motion
from vcran.core.opil.codec import decode_attribute
from vcran.core.opil.messages import RanStatus
from vcran.core.wire import Outbound


def manager_subscriptions(url: str) -> set[str]:
    return {s["id"] for s in httpx.get(f"{url}/v2/subscriptions").json()
            if s.get("description", "").startswith("vcran manage")}


def test_a_subscription_deleted_behind_manages_back_is_re_created_and_the_job_completes(broker_process, tmp_path):  # noqa: F811
    """Issue 30 item 2: while a job runs, ``vcran manage``'s subscription (the Dispatcher's attributes leave
    out robot_description, so it has one) is deleted through the broker's API. Its keeper finds it gone,
    re-creates it and reads what Orion holds, so the manager hears the robots again and the job completes
    (before, it never heard of them again: the job stayed open until the run's duration)."""
    url = broker_process
    live = warehouse_live(url, tmp_path / "live")
    try:
        manage = vcran("manage", str(WAREHOUSE), "--orion", url, "--factor", "20", "--jobs", "1",
                       "--notify-url", f"http://127.0.0.1:{free_port()}/notify", "--out", str(tmp_path / "manage"))
        try:
            assert wait_until(lambda: len(manager_subscriptions(url)) == 1, 60)
            # the job runs: the manager has written its first task
            assert wait_until(lambda: "job_1" in json.dumps(httpx.get(f"{url}/v2/entities").json()), 60)
            for sid in manager_subscriptions(url):
                assert httpx.delete(f"{url}/v2/subscriptions/{sid}").status_code == 204
            out, err = manage.communicate(timeout=120)  # until_idle: it ends once the job has ended
        finally:
            if manage.poll() is None:
                stop(manage)
        assert manage.returncode == 0, err
        assert "1 job(s) arrived, 1 completed, 0 failed, 0 open" in out, out + err
        assert err.count("is gone from Orion; re-creating it") == 1, err
        assert err.count("subscribed to Orion: ") == 2, err  # at the start, and again
        assert manager_subscriptions(url) == set()  # and it deleted the new ones on its way out
    finally:
        stop(live)
    summary = json.loads((tmp_path / "manage" / "summary.json").read_text())
    assert summary["jobs"]["completed"] == 1


# --- in process -------------------------------------------------------------------------------------------


def manager_link(client: OrionClient, batches: list[list[Outbound]], **options: Any) -> OrionManagerLink:
    return OrionManagerLink(CallNow(), client, LinkOptions("ROBOT", ROBOTS, **options), None,  # type: ignore[arg-type]
                            batches.append)


def written(bodies: list[dict]) -> list[tuple[str, str]]:
    """(robot, task) of each motion_assignment in the batch updates Orion took, in the order it took them."""
    return [(e["id"], decode_attribute("motion_assignment", e["motion_assignment"]).task_id.description)
            for body in bodies for e in body["entities"] if "motion_assignment" in e]


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["401", "429", "404-drop"])
def test_a_refusing_orion_gets_a_bounded_number_of_the_managers_requests_and_every_write_in_the_end(mode, caplog):
    """docs/contract.md §7 (4xx is not an outage, vcran backs off and never floods Orion), on the manager's side: 40
    writes while Orion refuses every update (an expired token; 429 with Retry-After; a dropped connection
    and a 404 in turn) cost no more requests than the backoff allows, each cause is logged once, and once
    Orion takes updates again every write reaches it, each robot's in order. Before, each write was one
    request, and a refused one was dropped."""
    orion = RefusingOrion(mode)
    batches: list[list[Outbound]] = []
    link = manager_link(OrionClient("http://orion.test", transport=httpx.MockTransport(orion)), batches,
                        backoff_start=0.05, backoff_cap=0.4, poll_interval=1.0)
    with caplog.at_level(logging.WARNING, logger="vcran.orion"):
        began = time.monotonic()
        link.start(1.0, strict=True)  # polling: reads answer [], only updates are refused
        for n in range(40):
            link.write(ROBOTS[n % 2], "motion_assignment", motion(f"T{n}", f"T{n}_m", 1, 2, n, 0))
            time.sleep(0.05)
        during = orion.attempts
        elapsed = time.monotonic() - began
        faults = [r.getMessage() for r in caplog.records if r.getMessage().startswith("manager writes: ")]
        assert not link.inbound_idle  # the writes wait for Orion (an until_idle run goes on)
        orion.mode = "204"
        assert wait_until(lambda: link.inbound_idle, 30)  # the backoff's next attempt takes them all
        link.close()
    assert 2 <= during <= most_requests(elapsed, 0.05, 0.4, RETRY_AFTER[mode])
    assert sorted(written(orion.updates)) == sorted((ROBOTS[n % 2], f"T{n}") for n in range(40))  # none twice
    for robot in ROBOTS:
        assert [t for r, t in written(orion.updates) if r == robot] == [f"T{n}" for n in range(40) if ROBOTS[n % 2] == robot]
    assert link.writes == 40 and link.sender.counts.undeliverable == 0
    assert len(faults) == (2 if mode == "404-drop" else 1), faults  # one line per distinct cause


def test_a_write_orion_refuses_as_invalid_is_sent_once_more_then_reported_and_the_loop_can_end(caplog):
    """docs/contract.md §7 as for the fleet's ran_errors: content Orion refuses (400) is not resent in a loop; the
    write gets a second chance (another element of the body may have been the invalid one), then it is
    counted undeliverable and logged, and the manager's side is idle again, so an until_idle run ends."""
    orion = FakeOrion(update_status=400)
    link = manager_link(OrionClient("http://orion.test", transport=httpx.MockTransport(orion)), [])
    link.write("robot_1", "cancel_order", cancel("T"))  # the link is not started: the test drives the sender
    with caplog.at_level(logging.WARNING, logger="vcran.orion"):
        assert link.sender.deliver() is not None and not link.inbound_idle  # refused: one more try
        assert link.sender.deliver() is not None and link.inbound_idle  # refused again: given up
    assert link.sender.counts.undeliverable == 1 and link.writes == 0 and orion.updates == []
    assert "manager writes: 1 write(s) refused 2 times by Orion, not sent again" in caplog.text
    link.close()


class Outage(httpx.HTTPTransport):
    """HTTP to the broker, or, while ``down``, 503 for every request without asking it."""

    def __init__(self) -> None:
        super().__init__()
        self.down = False
        self.refused = 0

    def handle_request(self, request: httpx.Request) -> httpx.Response:
        if self.down:
            self.refused += 1
            return httpx.Response(503, json={"error": "ServiceUnavailable", "description": "down"})
        return super().handle_request(request)


def test_a_5xx_outage_loses_nothing_orion_holds_and_the_managers_writes_arrive_after_it(caplog):
    """docs/contract.md §7 on the manager's side: Orion answers 503 to the manager for a while, during which it loses
    the manager's subscriptions (as after a restart that kept its data) and a robot's ran_status changes,
    which nobody is notified of. Once Orion answers again, the keeper re-creates both subscriptions and
    reads the entities: the manager hears the change. What it wrote meanwhile is delivered; notifications
    come again (through the new subscriptions). The outage is one line per cause, and one when it is over."""
    broker = start_broker(port=0)
    url = broker.url
    put(url, "robot_1", ran_status=RanStatus(state="WAITING"))
    outage = Outage()
    batches: list[list[Outbound]] = []
    link = manager_link(OrionClient(url, transport=outage), batches, notify_url=f"http://127.0.0.1:{free_port()}/notify",
                        keepalive=0.05, backoff_start=0.05, backoff_cap=0.2)

    def heard(state: str) -> int:
        """How many times the manager was told robot_1's ran_status is ``state``."""
        return sum(("robot_1", "ran_status", RanStatus(state=state)) in updates(b) for b in batches)

    try:
        with caplog.at_level(logging.WARNING, logger="vcran.orion"):
            link.start(1.0, strict=True)
            assert heard("WAITING") == 1  # the first read
            before = manager_subscriptions(url)
            assert len(before) == 2
            outage.down = True
            link.write("robot_1", "cancel_order", cancel("during"))
            assert wait_until(lambda: link.inbound.fault is not None and link.outbound.fault is not None, 30)
            for sid in before:  # Orion loses them; a change meanwhile notifies nobody
                assert httpx.delete(f"{url}/v2/subscriptions/{sid}").status_code == 204
            put(url, "robot_1", ran_status=RanStatus(state="TASK"))
            refused = outage.refused
            assert wait_until(lambda: outage.refused > refused + 3, 30)  # still down: retried, with backoff
            assert not heard("TASK")
            outage.down = False
            assert wait_until(lambda: heard("TASK"), 30)  # read from Orion after re-subscribing
            after = manager_subscriptions(url)
            assert len(after) == 2 and not after & before
            assert wait_until(lambda: link.inbound_idle, 30)  # the write of the outage reached Orion
            stored = httpx.get(f"{url}/v2/entities/robot_1/attrs/cancel_order").json()
            assert decode_attribute("cancel_order", stored).task_id.description == "during"
            put(url, "robot_1", ran_status=RanStatus(state="WAITING"))  # notified again
            assert wait_until(lambda: heard("WAITING") == 2, 30)
            assert link.inbound.fault is None and link.outbound.fault is None
    finally:
        link.close()
        broker.stop()
    lines = [r.getMessage() for r in caplog.records]
    down = [m for m in lines if "retrying with backoff" in m]
    assert len(down) == len(set(down)) and {m.split(":")[0] for m in down} == {"manager subscription", "manager writes"}
    assert sorted(m.split(":")[0] for m in lines if "Orion is back" in m) == ["manager subscription", "manager writes"]


def test_a_failed_notification_is_read_from_orion_by_the_manager():
    """docs/contract.md §7 (no loss window), as tests/transports/test_live.py tests it for the fleet: Orion fails to
    deliver the manager's notifications (its listener unreachable) and says so in the subscription; the
    keeper reads the entities, so the change those notifications carried reaches the manager."""
    broker = start_broker(port=0)
    url = broker.url
    put(url, "robot_1", ran_status=RanStatus(state="WAITING"))
    batches: list[list[Outbound]] = []
    link = manager_link(OrionClient(url), batches, notify_url=f"http://127.0.0.1:{free_port()}/notify",
                        keepalive=0.05)
    try:
        link.start(1.0, strict=True)
        dead = f"http://127.0.0.1:{free_port()}/notify"  # every notification of it from now on fails
        (sid,) = [s for s in manager_subscriptions(url) if link._ours[s] is link.subscriptions[0]]
        patch = {"notification": {"http": {"url": dead}, "attrs": list(link.subscriptions[0].attrs)}}
        assert httpx.patch(f"{url}/v2/subscriptions/{sid}", json=patch).status_code == 204
        put(url, "robot_1", ran_status=RanStatus(state="TASK"))
        assert broker.wait_notifications(timeout=10)
        assert httpx.get(f"{url}/v2/subscriptions/{sid}").json()["notification"]["failsCounter"] >= 1
        assert wait_until(lambda: any(("robot_1", "ran_status", RanStatus(state="TASK")) in updates(b)
                                      for b in batches), 30)
    finally:
        link.close()
        broker.stop()
