"""The broker against Orion 4.7's own sources and functional tests, over real HTTP (review 7).

Each test names where Orion's behaviour is written down: a file of Orion's source tree at the recorded
commit (c678400ba, the 4.7.0 release's code) or one of its functional tests
(``test/functionalTest/cases/...``), which hold the exact HTTP answers Orion gives.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import httpx
import pytest
from broker_support import Listener

from vcran.broker import BrokerHandle, start_broker


@pytest.fixture
def broker() -> Iterator[BrokerHandle]:
    with start_broker() as handle:
        yield handle


@pytest.fixture
def client(broker: BrokerHandle) -> Iterator[httpx.Client]:
    with httpx.Client(base_url=broker.url, timeout=10) as c:
        yield c


def subscription(url: str = "http://127.0.0.1:9/notify", **fields: Any) -> dict[str, Any]:
    return {"subject": {"entities": [{"id": "r1"}]}, "notification": {"http": {"url": url}}, **fields}


def created(answer: httpx.Response) -> str:
    assert answer.status_code == 201, answer.text
    return answer.headers["Location"].rsplit("/", 1)[-1]


def bad(answer: httpx.Response, description: str, error: str = "BadRequest", status: int = 400) -> None:
    assert (answer.status_code, answer.json()) == (status, {"error": error, "description": description})


# --- subscriptions as Orion renders them ------------------------------------------------------------------


def test_a_subscription_renders_as_orion_s_to_json(client: httpx.Client) -> None:
    """apiTypesV2/Subscription.cpp ``Subscription::toJson``/``Notification::toJson``: an empty
    description, a zero throttling and an empty metadata list are left out; ``expires`` is printed from
    whole seconds in UTC (functional test 1853_typePattern_3a/pattern_type_subscription.test sends
    ``2050-04-05T14:00:00.00Z`` and reads ``2050-04-05T14:00:00.000Z``)."""
    body = subscription(description="", throttling=0, expires="2050-04-05T14:00:00.00Z")
    body["notification"]["metadata"] = []
    sid = created(client.post("/v2/subscriptions", json=body))
    shown = client.get(f"/v2/subscriptions/{sid}").json()
    assert "description" not in shown and "throttling" not in shown
    assert "metadata" not in shown["notification"]
    assert shown["expires"] == "2050-04-05T14:00:00.000Z"
    sid = created(client.post("/v2/subscriptions", json=subscription(expires="2050-04-05T16:00:00.999+02:00")))
    assert client.get(f"/v2/subscriptions/{sid}").json()["expires"] == "2050-04-05T14:00:00.000Z"


def test_a_failing_subscription_stays_active_with_whole_second_times(client: httpx.Client, broker) -> None:
    """No ``failed`` status since Orion 3.4.0 (orion-api.md, "Ambiguous subscription status failed not
    used"); functional test 1960_failure_stats_in_db_and_notifications shows ``"status": "active"`` next
    to ``failsCounter``. Delivery times are whole seconds (cache/subCache.h, int64_t)."""
    dead = Listener()
    dead.stop()
    sid = created(client.post("/v2/subscriptions", json=subscription(dead.url)))
    assert client.post("/v2/entities", json={"id": "r1", "a": {"value": 1}}).status_code == 201
    assert broker.wait_notifications(timeout=10)
    shown = client.get(f"/v2/subscriptions/{sid}").json()
    assert shown["status"] == "active"
    assert shown["notification"]["failsCounter"] == 1
    for key in ("lastNotification", "lastFailure"):
        assert shown["notification"][key].endswith(".000Z")


# --- pagination -------------------------------------------------------------------------------------------


def test_limit_zero_counts_without_listing(client: httpx.Client) -> None:
    """functional test 1041_GET_v2_entities_options_count/get_entities_option_count_multitenant.test,
    step 05: ``GET /v2/entities?limit=0&options=count`` is 200, ``[]``, ``Fiware-Total-Count: 1``; the
    same loop guard stops subscription lists (mongoBackend/mongoGetSubscriptions.cpp)."""
    assert client.post("/v2/entities", json={"id": "r1", "type": "ROBOT"}).status_code == 201
    created(client.post("/v2/subscriptions", json=subscription()))
    for path in ("/v2/entities", "/v2/subscriptions"):
        answer = client.get(f"{path}?limit=0&options=count")
        assert (answer.status_code, answer.json(), answer.headers["Fiware-Total-Count"]) == (200, [], "1")
    answer = client.post("/v2/op/query?limit=0&options=count", json={"entities": [{"idPattern": ".*"}]})
    assert (answer.status_code, answer.json(), answer.headers["Fiware-Total-Count"]) == (200, [], "1")


def test_a_limit_that_is_no_number_has_orion_s_words(client: httpx.Client) -> None:
    """rest/rest.cpp ``uriArgumentGet``: limit "must be a positive integer number", offset "must be a
    decimal number"."""
    bad(client.get("/v2/entities?limit=2x"), "Bad pagination limit: /2x/ [must be a positive integer number]")
    bad(client.get("/v2/subscriptions?offset=-1"), "Bad pagination offset: /-1/ [must be a decimal number]")
