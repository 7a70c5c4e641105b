"""``options=forcedUpdate`` as Orion 4.7 implements it (docs/contract.md §7; issue 29 item 2): vcran's live sender writes
``robot_description`` with it, so that a planner subscribing late still gets the description (docs/contract.md §2).

Ground truth, from telefonicaid/fiware-orion at 4.7.0 (c678400):

- ``src/lib/serviceRoutinesV2/postUpdateContext.cpp`` reads the option for every update that goes through
  it: ``POST``/``PATCH``/``PUT /v2/entities/{id}/attrs``, ``PUT .../attrs/{name}``, ``PUT .../value`` and
  ``POST /v2/op/update``;
- ``src/lib/mongoBackend/MongoCommonUpdate.cpp``, ``mergeAttrInfo``: ``valueChanged = forcedUpdate ||
  attrValueChanges(...)``: every *written* attribute counts as changed (so it is in
  ``attrsWithModifiedValue``, which the subscriptions' ``condition.attrs`` are matched against), its
  modification date and the entity's move;
- the functional tests ``test/functionalTest/cases/3389_forced_update_option/*.test``, replayed below step
  by step.
"""

from __future__ import annotations

import random
from typing import Any

import pytest

from tests.conftest import HandClock
from vcran.broker import Broker, Outcome, Request

URL = "http://127.0.0.1:9/notify"
T0 = 1_700_000_000.0

#: 3389_forced_update_option_string.test, step 01: a subscription to Slot1's ``availability``.
SUBSCRIPTION = {
    "description": "A subscription to get info about Slot1",
    "subject": {"entities": [{"id": "Slot1", "type": "Slot"}], "condition": {"attrs": ["availability"]}},
    "notification": {"http": {"url": URL}, "attrs": ["availability"]},
}
SLOT1 = {"id": "Slot1", "type": "Slot", "availability": {"value": "Avaliable", "type": "Text"}}  # sic
SAME = {"availability": {"value": "Avaliable", "type": "Text"}}
NOTIFIED = [{"id": "Slot1", "type": "Slot", "availability": {"type": "Text", "value": "Avaliable", "metadata": {}}}]


def call(broker: Broker, method: str, target: str, body: Any = None, content_type: str | None = None) -> Outcome:
    headers = {"Content-Type": content_type} if content_type else None
    raw = body.encode() if isinstance(body, str) else body
    outcome = broker.handle(Request.make(method, target, raw, headers))
    assert outcome.response.status in (201, 204), outcome.response.body
    return outcome


def notified(outcome: Outcome) -> list[dict[str, Any]]:
    return [entity for n in outcome.notifications for entity in n.json()["data"]]


@pytest.fixture
def clock() -> HandClock:
    return HandClock(T0)


@pytest.fixture
def broker(clock: HandClock) -> Broker:
    """Steps 01-03: the subscription, then Slot1 created (which notifies)."""
    b = Broker(clock=clock, rng=random.Random(3389))
    call(b, "POST", "/v2/subscriptions", SUBSCRIPTION)
    assert notified(call(b, "POST", "/v2/entities", SLOT1)) == NOTIFIED
    return b


# Steps 04-15 of 3389_forced_update_option_{string,number,bool}.test: each rewrites the same value and
# notifies (step 06, an append of another attribute, notifies nobody: the condition names availability).
@pytest.mark.parametrize(("method", "target", "body", "content_type", "expected"), [
    ("POST", "/v2/entities/Slot1/attrs?options=forcedUpdate", SAME, None, NOTIFIED),
    ("POST", "/v2/entities/Slot1/attrs?options=append,forcedUpdate",
     {"lift": {"value": "Avaliable", "type": "Text"}}, None, []),
    ("PUT", "/v2/entities/Slot1/attrs?options=forcedUpdate", SAME, None, NOTIFIED),
    ("PUT", "/v2/entities/Slot1/attrs/availability?options=forcedUpdate", {"value": "Avaliable"}, None, NOTIFIED),
    ("PUT", "/v2/entities/Slot1/attrs/availability/value?options=forcedUpdate", '"Avaliable"', "text/plain",
     NOTIFIED),
    ("PATCH", "/v2/entities/Slot1/attrs?options=forcedUpdate", SAME, None, NOTIFIED),
], ids=["post-attrs", "append-other-attr", "put-attrs", "put-attr", "put-value", "patch-attrs"])
def test_3389_forced_update_notifies_a_same_value_write_on_every_update_endpoint(
        broker, method, target, body, content_type, expected):
    assert notified(call(broker, method, target, body, content_type)) == expected


@pytest.mark.parametrize("action", ["update", "append"])
def test_3389_batch_forced_update_notifies_and_a_plain_same_value_batch_does_not(broker, action):
    """3389_forced_update_option_batch_string.test, steps 05-10 (one entity here)."""
    batch = {"actionType": action, "entities": [SLOT1]}
    assert notified(call(broker, "POST", "/v2/op/update", batch)) == []  # step 06: no actual update
    assert notified(call(broker, "POST", "/v2/op/update?options=forcedUpdate", batch)) == NOTIFIED  # 08, 10


def test_forced_update_moves_date_modified_and_counts_only_the_written_attributes(broker, clock):
    """``mergeAttrInfo``: a forced write is a modification (the entity's ``dateModified`` moves, as
    ``processContextElement`` stamps ``ENT_MODIFICATION_DATE`` for a modified entity), of the written
    attributes only: a subscription on another attribute is not triggered, and ``onlyChangedAttrs``
    shows the written one."""
    call(broker, "POST", "/v2/entities/Slot1/attrs", {"lift": {"value": 1}})
    on_lift = {"subject": {"entities": [{"id": "Slot1"}], "condition": {"attrs": ["lift"]}},
               "notification": {"http": {"url": URL}}}
    only_changed = {"subject": {"entities": [{"id": "Slot1"}]},
                    "notification": {"http": {"url": URL}, "onlyChangedAttrs": True}}
    call(broker, "POST", "/v2/subscriptions", on_lift)
    call(broker, "POST", "/v2/subscriptions", only_changed)

    def modified() -> str:
        return broker.handle(Request.make("GET", "/v2/entities/Slot1?attrs=dateModified")).response.json()[
            "dateModified"]["value"]

    before = modified()
    clock.now += 10
    assert notified(call(broker, "PATCH", "/v2/entities/Slot1/attrs", SAME)) == []  # a same value, not forced
    assert modified() == before
    outcome = call(broker, "PATCH", "/v2/entities/Slot1/attrs?options=forcedUpdate", SAME)
    # the availability subscription (whole notification.attrs) and the onlyChangedAttrs one; not the lift one
    assert notified(outcome) == [*NOTIFIED, NOTIFIED[0]]
    assert modified() == "2023-11-14T22:13:30.000Z"  # T0 + 10 s
