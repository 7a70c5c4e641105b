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
