"""The broker under input a well-behaved client never sends (issue 12): what Orion refuses, the broker
refuses, with Orion's answer, and nothing it stores can break a later read."""

from __future__ import annotations

from collections.abc import Iterator

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


def post_json(client: httpx.Client, path: str, text: str) -> httpx.Response:
    return client.post(path, content=text.encode(), headers={"Content-Type": "application/json"})


LONE = '"\\udc00"'  # JSON text of a lone low surrogate: valid JSON syntax, not a Unicode string


@pytest.mark.parametrize("path,body", [
    ("/v2/entities", '{"id": "r1", "type": "ROBOT", "cancel_order": {"value": ' + LONE + '}}'),
    ("/v2/entities", '{"id": "r1", "type": "ROBOT", "cancel_order": {"value": {"deep": [' + LONE + ']}}}'),
    ("/v2/entities", '{"id": "r1", "type": "ROBOT", ' + LONE + ': {"value": 1}}'),
    ("/v2/op/update", '{"actionType": "append", "entities": [{"id": "r1", "type": "ROBOT", "a": {"value": '
     + LONE + '}}]}'),
])
def test_a_lone_surrogate_is_refused_like_orion_and_reads_keep_working(client, broker, path, body):
    listener = Listener()
    try:
        subscription = {"subject": {"entities": [{"idPattern": ".*"}]}, "notification": {"http": {"url": listener.url}}}
        assert client.post("/v2/subscriptions", json=subscription).status_code == 201
        answer = post_json(client, path, body)
        assert answer.status_code == 400
        assert answer.json() == {"error": "ParseError", "description": "Errors found in incoming JSON buffer"}
        assert broker.wait_notifications(timeout=5)
        assert listener.take() == []  # nothing applied, nothing notified
        assert client.get("/v2/entities").status_code == 200
        assert client.get("/v2/entities").json() == []
        assert client.get("/v2/entities/r1").status_code == 404
    finally:
        listener.stop()


def test_a_surrogate_pair_is_a_character_and_is_stored(client):
    """Only lone surrogates are refused: an escaped pair is one astral character (U+1F600)."""
    assert post_json(client, "/v2/entities", '{"id": "r1", "a": {"value": "\\ud83d\\ude00"}}').status_code == 201
    assert client.get("/v2/entities/r1/attrs/a").json()["value"] == "\U0001F600"


# --- options (docs/contract.md §7: every value Orion 4.7 accepts) -------------------------------------------------------

#: Orion 4.7's list of valid ``options`` items (its documentation and rest/ConnectionInfo.cpp).
ORION_OPTIONS = ["count", "normalized", "values", "keyValues", "append", "unique", "dateCreated", "dateModified",
                 "noAttrDetail", "upsert", "forcedUpdate", "overrideMetadata", "flowControl", "skipForwarding",
                 "fullCounters", "libVersions", "skipInitialNotification"]


@pytest.mark.parametrize("option", ORION_OPTIONS)
def test_every_option_orion_accepts_is_accepted(client, option):
    assert client.post("/v2/entities", json={"id": "r1", "type": "ROBOT", "a": {"value": 1}}).status_code == 201
    assert client.get(f"/v2/entities?options={option}").status_code == 200
    assert client.get(f"/v2/entities/r1?options={option}").status_code == 200
    update = {"actionType": "append", "entities": [{"id": "r1", "type": "ROBOT", "a": {"value": 2}}]}
    assert client.post(f"/v2/op/update?options={option}", json=update).status_code == 204


@pytest.mark.parametrize("options,status", [
    ("normalized", 200), ("normalized,count", 200), (",count", 200),  # Orion skips leading commas
    ("count,", 400), ("count,,values", 400), ("nope", 400),
    ("keyValues,values", 400), ("keyValues,unique", 400), ("unique,values", 400),  # Orion's exclusions
])
def test_options_lists_are_split_and_checked_as_orion_does(client, options, status):
    answer = client.get(f"/v2/entities?options={options}")
    assert answer.status_code == status
    if status == 400:
        assert answer.json() == {"error": "BadRequest", "description": "Invalid value for URI param /options/"}


def test_options_unique_lists_each_distinct_value_once(client):
    entity = {"id": "r1", "a": {"value": 1}, "b": {"value": 1.0}, "c": {"value": "x"}, "d": {"value": {"k": 1}},
              "e": {"value": {"k": 1}}, "f": {"value": "x"}}
    assert client.post("/v2/entities", json=entity).status_code == 201
    assert client.get("/v2/entities/r1?options=unique").json() == [1, "x", {"k": 1}]
    assert client.get("/v2/entities?options=unique").json() == [[1, "x", {"k": 1}]]


def test_builtin_dates_are_shown_when_asked_and_move_only_on_a_change():
    import random

    from vcran.broker import Broker, Request

    now = [1_700_000_000.25]
    broker = Broker(clock=lambda: now[0], rng=random.Random(1))

    def call(method, target, body=None):
        return broker.handle(Request.make(method, target, body)).response

    assert call("POST", "/v2/entities", {"id": "r1", "a": {"value": 1}}).status == 201
    now[0] += 10
    assert call("POST", "/v2/entities/r1/attrs", {"a": {"value": 1}}).status == 204  # same value: no change
    assert call("GET", "/v2/entities/r1?options=keyValues,dateCreated,dateModified").json() == {
        "id": "r1", "type": "Thing", "a": 1,
        "dateCreated": "2023-11-14T22:13:20.250Z", "dateModified": "2023-11-14T22:13:20.250Z"}
    now[0] += 10
    assert call("POST", "/v2/entities/r1/attrs", {"a": {"value": 2}}).status == 204
    assert call("GET", "/v2/entities/r1?attrs=dateModified,a").json() == {
        "id": "r1", "type": "Thing",
        "dateModified": {"type": "DateTime", "value": "2023-11-14T22:13:40.250Z", "metadata": {}},
        "a": {"type": "Number", "value": 2, "metadata": {}}}
    assert call("GET", "/v2/entities/r1").json() == {"id": "r1", "type": "Thing",
                                                     "a": {"type": "Number", "value": 2, "metadata": {}}}
