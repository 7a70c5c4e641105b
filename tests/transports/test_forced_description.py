"""``robot_description`` reaches a planner that subscribes late (docs/contract.md §2; issue 29 item 2).

The description goes out at start and every ``description_period`` and never changes; Orion notifies only
changes, so vcran's live sender writes it with ``options=forcedUpdate`` in a request of its own. Here the
sender talks to vcran's broker engine in process (httpx.MockTransport, a hand-moved clock): no sockets,
no waiting, and the broker's forcedUpdate is Orion's (tests/broker/test_broker_forced_update.py).
"""

from __future__ import annotations

import json
import random
from urllib.parse import parse_qs, urlsplit

import httpx
import numpy as np

from tests.conftest import HandClock
from transports.orion.client import OrionClient
from transports.orion.link import LinkOptions
from transports.orion.transport import OrionTransport
from vcran.broker import Broker, Request
from vcran.core.opil.codec import decode_attribute, encode_entity_json
from vcran.core.opil.messages import AssignmentStatus, PolygonStamped, RanStatus
from vcran.core.scenario import RobotConfig
from vcran.core.wire import Frame, Publish
from vcran.sim.opil.ran import description

ROBOTS = ("robot_1", "robot_2")
URL = "http://planner.test/notify"


class InProcessOrion:
    """vcran's broker engine behind httpx.MockTransport: every request, and every notification it makes."""

    def __init__(self, fail_forced: int = 0) -> None:
        self.clock = HandClock(1_700_000_000.0)
        self.broker = Broker(clock=self.clock, rng=random.Random(29))
        self.requests: list[tuple[str, dict[str, list[str]], bytes]] = []
        self.notified: list[tuple[str, dict]] = []  # (subscription id, entity)
        self.fail_forced = fail_forced  # answer 503 to this many forcedUpdate requests

    def __call__(self, request: httpx.Request) -> httpx.Response:
        query = parse_qs(urlsplit(str(request.url)).query)
        if "forcedUpdate" in query.get("options", [""])[0] and self.fail_forced:
            self.fail_forced -= 1
            return httpx.Response(503)
        self.requests.append((request.url.path, query, request.content))
        outcome = self.broker.handle(Request(request.method, request.url.raw_path.decode(),
                                             tuple((k.decode(), v.decode()) for k, v in request.headers.raw),
                                             request.content))
        for n in outcome.notifications:
            self.notified += [(n.subscription_id, entity) for entity in n.json()["data"]]
        return httpx.Response(outcome.response.status, headers=list(outcome.response.headers),
                              content=outcome.response.body)

    def subscribe_late(self, attribute: str) -> str:
        """A FIROS-style subscription (one attribute, iml130/firos cbSubscriber.py), made now."""
        body = {"subject": {"entities": [{"id": "robot_1", "type": "ROBOT"}], "condition": {"attrs": [attribute]}},
                "notification": {"http": {"url": URL}, "attrs": [attribute]}}
        response = self.broker.handle(Request.make("POST", "/v2/subscriptions", body)).response
        assert response.status == 201
        return str(response.header("Location")).rsplit("/", 1)[1]

    def forced_bodies(self) -> list[bytes]:
        return [body for path, query, body in self.requests if query.get("options") == ["forcedUpdate"]]


def fleet(orion: InProcessOrion) -> tuple[OrionTransport, dict[str, object]]:
    client = OrionClient("http://orion.test", transport=httpx.MockTransport(orion))
    configs = [RobotConfig(id=r) for r in ROBOTS]
    descriptions = {c.id: description(c, PolygonStamped.from_xy(c.footprint)) for c in configs}
    for r in ROBOTS:  # what `vcran orion init` writes first (the original VC-RAN's "Initialize FOCB")
        client.update(b'{"actionType":"append","entities":[' + encode_entity_json(r, "ROBOT", {
            "robot_description": descriptions[r], "ran_status": RanStatus()}) + b"]}")
    return OrionTransport(client, LinkOptions("ROBOT", ROBOTS)), descriptions


def tick(t: OrionTransport, now: float, *publications: tuple[str, str, object]) -> None:
    """One telemetry tick: the publications of this instant, the fleet's frame, then the sender's delivery."""
    for robot, attribute, message in publications:
        t.send(Publish(now, robot, attribute, message))  # type: ignore[arg-type]
    t.send(Frame(now, ROBOTS, np.zeros((len(ROBOTS), 5))))
    assert t.sender.deliver() is None


def test_a_planner_that_subscribes_late_gets_the_description_at_the_next_periodic_write():
    orion = InProcessOrion()
    t, descriptions = fleet(orion)
    status = AssignmentStatus()
    tick(t, 0.0, *((r, "robot_description", descriptions[r]) for r in ROBOTS), ("robot_1", "assignment_state", status))
    late_description = orion.subscribe_late("robot_description")  # the planner starts after vcran
    late_status = orion.subscribe_late("assignment_state")
    for now in (1.0, 2.0):  # ticks carry current_motion only: nothing the planner subscribed to changed
        tick(t, now)
    assert orion.notified == []
    # the next periodic write (description_period later; the same values): the description reaches it,
    # the unchanged assignment_state written with it in the same tick does not
    tick(t, 60.0, *((r, "robot_description", descriptions[r]) for r in ROBOTS), ("robot_1", "assignment_state", status))
    assert [(sid, sorted(entity)) for sid, entity in orion.notified] == [
        (late_description, ["id", "robot_description", "type"])]
    assert decode_attribute("robot_description", orion.notified[0][1]["robot_description"]) == descriptions["robot_1"]
    assert late_status not in {sid for sid, _ in orion.notified}


def test_only_the_description_is_forced_in_one_request_for_the_whole_fleet():
    """forcedUpdate forces every attribute of its request (Orion's mergeAttrInfo), so the forced request
    holds the descriptions and nothing else; one for the fleet, as the tick's request is (docs/contract.md §7)."""
    orion = InProcessOrion()
    t, descriptions = fleet(orion)
    del orion.requests[:]  # those of `vcran orion init`
    tick(t, 0.0, *((r, "robot_description", descriptions[r]) for r in ROBOTS),
         *((r, "ran_status", RanStatus(state="TASK")) for r in ROBOTS))
    tick_request, forced = (json.loads(body) for _, _, body in orion.requests)
    assert orion.forced_bodies() == [orion.requests[1][2]]
    assert [sorted(e) for e in forced["entities"]] == [["id", "robot_description", "type"]] * len(ROBOTS)
    assert [sorted(e) for e in tick_request["entities"]] == [["current_motion", "id", "ran_status", "type"]] * len(ROBOTS)


def test_a_forced_write_that_fails_is_sent_again_forced():
    orion = InProcessOrion(fail_forced=1)
    t, descriptions = fleet(orion)
    late = orion.subscribe_late("robot_description")
    t.send(Publish(60.0, "robot_1", "robot_description", descriptions["robot_1"]))
    t.send(Frame(60.0, ROBOTS, np.zeros((len(ROBOTS), 5))))
    assert t.sender.deliver() is not None  # the forced request failed (503): back off, keep it
    assert orion.notified == [] and len(orion.forced_bodies()) == 0
    assert t.sender.deliver() is None
    assert [sid for sid, _ in orion.notified] == [late]
