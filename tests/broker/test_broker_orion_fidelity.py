"""The broker against Orion 4.7's own sources and functional tests, over real HTTP (review 7).

Each test names where Orion's behaviour is written down: a file of Orion's source tree at the recorded
commit (c678400ba, the 4.7.0 release's code) or one of its functional tests
(``test/functionalTest/cases/...``), which hold the exact HTTP answers Orion gives.
"""

from __future__ import annotations

import json
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


# --- subscription payloads ----------------------------------------------------------------------------------

URL = "http://localhost:1234"
SUBJECT = {"entities": [{"id": "xxx", "type": "special"}]}
NOTIFICATION = {"http": {"url": URL}}


@pytest.mark.parametrize("body, description", [
    # 1316_create_subscription/post_subs_errors.test, steps 01-03, 06-09
    ({"subject": {"entities": [{"type": "T"}]}, "notification": NOTIFICATION},
     "/entities/ vector item does not have /id/ nor /idPattern/"),
    ({"subject": {"entities": {"id": "xxx"}}, "notification": NOTIFICATION}, "/entities/ is not an array"),
    ({"subject": {"entities": [{"id": "one", "idPattern": "two"}]}, "notification": NOTIFICATION},
     "/entities/ vector item has both /id/ and /idPattern/"),
    ({"notification": NOTIFICATION}, "no subject for subscription specified"),
    ({"subject": SUBJECT}, "no notification for subscription specified"),
    ({"subject": {**SUBJECT, "condition": {}}, "notification": NOTIFICATION}, "condition is empty"),
    ({"subject": SUBJECT, "notification": {"http": {"url": "http://"}}}, "Invalid URL parsing notification url"),
    # 1947_1972_invalid_subs_crash/1947_1972_invalid_subs_crash.test, steps 01-09, 15-17
    ({"subject": {"entities": [{"id": {"x": "y"}}]}, "notification": NOTIFICATION},
     "/entities/ vector item /id/ is not a string"),
    ({"subject": {"entities": [{"idPattern": 1}]}, "notification": NOTIFICATION},
     "/entities/ vector item /idPattern/ is not a string"),
    ({"subject": {"entities": [{"id": "xxx", "type": 1}]}, "notification": NOTIFICATION},
     "/entities/ vector item type is not a string"),
    ({"subject": [SUBJECT], "notification": NOTIFICATION}, "subject is not an object"),
    ({"subject": SUBJECT, "notification": [{}]}, "notification is not an object"),
    ({"subject": SUBJECT, "notification": NOTIFICATION, "expires": ["1991-04-05T14:00:00.00Z"]},
     "expires is not a string"),
    ({"subject": {**SUBJECT, "condition": []}, "notification": NOTIFICATION}, "condition is not an object"),
    ({"subject": {**SUBJECT, "condition": {"attrs": 0}}, "notification": NOTIFICATION},
     "the field /attrs/ must be a JSON array"),
    ({"subject": SUBJECT, "notification": {**NOTIFICATION, "attrs": "temperature"}},
     "the field /attrs/ must be a JSON array"),
    ({"subject": SUBJECT, "notification": {"http": {"url": {"url": URL}}}}, "url http notification is not a string"),
    ({"subject": SUBJECT, "notification": NOTIFICATION, "throttling": [2.5]}, "throttling is not an int"),
    # jsonParseV2/parseSubscription.cpp, parseEntitiesVector.cpp, parseStringVector.cpp, errorMessages.h
    ({"subject": {"entities": []}, "notification": NOTIFICATION}, "subject entities is empty"),
    ({"subject": SUBJECT, "notification": {"httpCustom": {"url": URL}, **NOTIFICATION}},
     "only one of http, httpCustom, mqtt, mqttCustom, kafka or kafkaCustom is allowed"),
    ({"subject": SUBJECT, "notification": {"attrs": []}},
     "http, httpCustom, mqtt, mqttCustom, kafka or kafkaCustom is missing"),
    ({"subject": SUBJECT, "notification": {"http": {}}}, "url http notification is missing"),
    ({"subject": SUBJECT, "notification": {"http": {"url": "mqtt://localhost:1883"}}},
     "mqtt URL cannot be used in http notifications"),
    ({"subject": SUBJECT, "notification": NOTIFICATION, "status": "failed"},
     "status is not valid: it has to be either active, inactive or oneshot"),
    ({"subject": SUBJECT, "notification": {**NOTIFICATION, "attrsFormat": "legacy"}},
     "invalid attrsFormat, accepted values: normalized, simplifiedNormalized, keyValues, simplifiedkeyValues, "
     "values"),
    ({"subject": SUBJECT, "notification": {**NOTIFICATION, "attrs": ["a", "b", "a"]}}, "duplicated item /a/ in array"),
    ({"subject": SUBJECT, "notification": {**NOTIFICATION, "attrs": ["a b"]}}, "forbidden characters in attribute name"),
    ({"subject": SUBJECT, "notification": {**NOTIFICATION, "attrs": [""]}},
     "empty string found in string vector /attrs/"),
    ({"subject": SUBJECT, "notification": {**NOTIFICATION, "attrs": [1]}},
     "only JSON Strings allowed in string vector /attrs/"),
    ({"subject": SUBJECT, "notification": {**NOTIFICATION, "onlyChangedAttrs": "yes"}}, "onlyChangedAttrs is not a bool"),
    ({"subject": SUBJECT, "notification": {**NOTIFICATION, "maxFailsLimit": 0}},
     "maxFailsLimit must be greater than zero"),
    ({"subject": SUBJECT, "notification": {"http": {"url": URL, "timeout": -1}}},
     "timeout field must be an integer between 0 and 1800000"),
    ({"subject": {"entities": [{"id": ""}]}, "notification": NOTIFICATION}, "/entities/ element id is empty"),
    ({"subject": {"entities": [{"id": "a/b"}]}, "notification": NOTIFICATION},
     "forbidden characters in /entities/ vector item /id/"),
    ({"subject": SUBJECT, "notification": NOTIFICATION, "description": None}, "description is not a string"),
])  # fmt: skip
def test_subscription_payload_errors_have_orion_s_words(client: httpx.Client, body: dict, description: str) -> None:
    bad(client.post("/v2/subscriptions", json=body), description)


@pytest.mark.parametrize("body", [[SUBJECT], "x", 1])
def test_a_subscription_payload_that_is_no_object_is_a_parse_error(client: httpx.Client, body: Any) -> None:
    """1316_create_subscription/post_subs_errors.test step 04: "Errors found in incoming JSON buffer"."""
    bad(client.post("/v2/subscriptions", json=body), "Errors found in incoming JSON buffer", "ParseError")


def test_negative_throttling_is_accepted_and_means_none(client: httpx.Client) -> None:
    """parseSubscription.cpp takes any int64 (getInt64Opt); Subscription::toJson shows it only above 0."""
    sid = created(client.post("/v2/subscriptions", json=subscription(throttling=-5)))
    assert "throttling" not in client.get(f"/v2/subscriptions/{sid}").json()


def test_http_timeout_is_shown_and_bounds_the_delivery(client: httpx.Client, broker) -> None:
    """apiTypesV2/HttpInfo.cpp shows ``timeout`` when above 0; a listener slower than it is a failure
    ("Timeout was reached", libcurl's words)."""
    import threading

    release = threading.Event()
    slow = Listener(gate=release)
    try:
        sid = created(client.post("/v2/subscriptions", json={"subject": {"entities": [{"id": "r1"}]},
                                                             "notification": {"http": {"url": slow.url, "timeout": 200}}}))
        assert client.get(f"/v2/subscriptions/{sid}").json()["notification"]["http"] == {"url": slow.url, "timeout": 200}
        assert client.post("/v2/entities", json={"id": "r1", "a": {"value": 1}}).status_code == 201
        assert broker.wait_notifications(timeout=10)
        shown = client.get(f"/v2/subscriptions/{sid}").json()["notification"]
        assert (shown["failsCounter"], shown["lastFailureReason"]) == (1, "Timeout was reached")
    finally:
        release.set()
        slow.stop()


def test_max_fails_limit_deactivates_after_that_many_failures(client: httpx.Client, broker) -> None:
    """3541_subscription_max_fails_limit/http_subscription_passes_to_inactive_state_after_limit_of_failed_
    connection_attemps.test: with ``maxFailsLimit: 5`` the status is ``active`` at failsCounter 5 and
    ``inactive`` at 6 (cache/subCache.cpp: ``failsCounter >= maxFailsLimit`` before counting)."""
    dead = Listener()
    dead.stop()
    sid = created(client.post("/v2/subscriptions", json={"subject": {"entities": [{"id": "r1"}]},
                                                         "notification": {"http": {"url": dead.url}, "maxFailsLimit": 2}}))
    assert client.post("/v2/entities", json={"id": "r1", "a": {"value": 0}}).status_code == 201
    for value in (1, 2):
        assert broker.wait_notifications(timeout=10)
        shown = client.get(f"/v2/subscriptions/{sid}").json()
        assert (shown["status"], shown["notification"]["maxFailsLimit"]) == ("active", 2)
        assert client.patch("/v2/entities/r1/attrs", json={"a": {"value": value}}).status_code == 204
    assert broker.wait_notifications(timeout=10)
    shown = client.get(f"/v2/subscriptions/{sid}").json()
    assert (shown["status"], shown["notification"]["failsCounter"]) == ("inactive", 3)
    assert client.patch("/v2/entities/r1/attrs", json={"a": {"value": 9}}).status_code == 204
    assert broker.wait_notifications(timeout=10)
    assert client.get(f"/v2/subscriptions/{sid}").json()["notification"]["timesSent"] == 3


def test_a_notification_without_attrs_format_resets_it_on_update(client: httpx.Client) -> None:
    """parseSubscription.cpp parseNotification: a ``notification`` without ``attrsFormat`` sets the
    default (normalized), on PATCH too."""
    sid = created(client.post("/v2/subscriptions", json={"subject": SUBJECT,
                                                         "notification": {**NOTIFICATION, "attrsFormat": "keyValues"}}))
    assert client.patch(f"/v2/subscriptions/{sid}", json={"notification": NOTIFICATION}).status_code == 204
    assert client.get(f"/v2/subscriptions/{sid}").json()["notification"]["attrsFormat"] == "normalized"


# --- batch payloads -----------------------------------------------------------------------------------------


@pytest.mark.parametrize("path, body, description", [
    # jsonParseV2/parseBatchUpdate.cpp and parseEntityObject.cpp
    ("/v2/op/update", {}, "empty payload"),
    ("/v2/op/update", {"entities": []}, "Invalid JSON payload, mandatory field /actionType/ not found"),
    ("/v2/op/update", {"actionType": "append"}, "Invalid JSON payload, mandatory field /entities/ not found"),
    ("/v2/op/update", {"actionType": "nope", "entities": [{"id": "r1"}]},
     "invalid update action type: right ones are: append, appendStric, delete, replace, update"),
    ("/v2/op/update", {"actionType": "append", "entities": {"id": "r1"}}, "not a JSON array"),
    ("/v2/op/update", {"actionType": "append", "entities": ["r1"]}, "entity is not a JSON object"),
    ("/v2/op/update", {"actionType": "append", "entities": [{"type": "T"}]}, "nor /id/ nor /idPattern/ present"),
    ("/v2/op/update", {"actionType": "append", "entities": [{"id": "r1"}], "options": "upsert"},
     "Unrecognized field in JSON payload: /options/"),
    # jsonParseV2/parseBatchQuery.cpp
    ("/v2/op/query", {}, "empty payload"),
    ("/v2/op/query", {"limit": 5}, "Invalid JSON payload, no relevant fields found"),
    ("/v2/op/query", {"entities": [{"idPattern": ".*"}], "limit": 5}, "Unrecognized field in JSON payload: /limit/"),
    ("/v2/op/query", {"entities": {"idPattern": ".*"}}, "not a JSON array"),
    ("/v2/op/query", {"attrs": "a"}, "the field /attrs/ must be a JSON array"),
    ("/v2/op/query", {"attrs": [1]}, "only JSON Strings allowed in attrs list"),
    ("/v2/op/query", {"entities": [{"id": "r1", "idPattern": "r"}]}, "both /id/ and /idPattern/ present"),
    ("/v2/op/query", {"entities": [{"id": "r1", "a": {"value": 1}}]}, "no attributes allowed in Entity in this payload"),
    ("/v2/op/query", {"entities": [{"id": 1}]}, "Invalid JSON type for entity id"),
    ("/v2/op/query", {"entities": [{"id": "a b"}]}, "Invalid characters in entity id"),
])  # fmt: skip
def test_batch_payload_errors_have_orion_s_words(client: httpx.Client, path: str, body: dict, description: str) -> None:
    bad(client.post(path, json=body), description)


@pytest.mark.parametrize("path", ["/v2/op/update", "/v2/op/query"])
def test_a_batch_payload_that_is_no_object_is_a_parse_error(client: httpx.Client, path: str) -> None:
    """parseBatchUpdate.cpp / parseBatchQuery.cpp: ``!document.IsObject()`` is ERROR_PARSE."""
    bad(client.post(path, json=[{"id": "r1"}]), "Errors found in incoming JSON buffer", "ParseError")


def test_id_pattern_in_op_update_is_not_implemented_as_in_orion(client: httpx.Client) -> None:
    """parseEntityObject.cpp returns ERROR_NOTIMPLEMENTED for idPattern when it is not allowed;
    parseBatchUpdate.cpp answers it 501 ``{"error": "NotImplemented", "description": "NotImplemented"}``."""
    answer = client.post("/v2/op/update", json={"actionType": "delete", "entities": [{"idPattern": ".*"}]})
    bad(answer, "NotImplemented", "NotImplemented", 501)


# --- patterns -------------------------------------------------------------------------------------------------


def test_patterns_match_anywhere_in_the_id_as_orion_s_regex_search(client: httpx.Client, broker) -> None:
    """Orion matches idPattern/typePattern with MongoDB's ``$regex`` (mongoBackend/MongoGlobal.cpp
    appendRegex) and ``regexec`` (cache/subCache.cpp), both unanchored: ``obot`` matches ``robot_1``."""
    listener = Listener()
    try:
        body = {"subject": {"entities": [{"idPattern": "obot", "typePattern": "OBO"}]},
                "notification": {"http": {"url": listener.url}}}
        created(client.post("/v2/subscriptions", json=body))
        for entity_id in ("robot_1", "other"):
            assert client.post("/v2/entities", json={"id": entity_id, "type": "ROBOT", "a": {"value": 1}}).status_code == 201
        assert [e["id"] for e in client.get("/v2/entities?idPattern=obot").json()] == ["robot_1"]
        assert [e["id"] for e in client.get("/v2/entities?typePattern=OBO").json()] == ["robot_1", "other"]
        assert [e["id"] for e in client.get("/v2/entities?idPattern=^obot").json()] == []
        query = {"entities": [{"idPattern": "_1", "typePattern": "^R"}]}
        assert [e["id"] for e in client.post("/v2/op/query", json=query).json()] == ["robot_1"]
        assert broker.wait_notifications(timeout=10)
        assert [json.loads(n.body)["data"][0]["id"] for n in listener.take()] == ["robot_1"]
    finally:
        listener.stop()


# --- entity and attribute payloads ------------------------------------------------------------------------


@pytest.mark.parametrize("path, body, description", [
    # jsonParseV2/parseEntity.cpp
    ("/v2/entities", {"type": "ROBOT"}, "entity id length: 0, min length supported: 1"),
    ("/v2/entities", {"id": 1}, "Invalid JSON type for entity id"),
    ("/v2/entities", {"id": "r1", "type": ""}, "entity type length: 0, min length supported: 1"),
    ("/v2/entities/r1/attrs", {}, "empty payload"),
    # jsonParseV2/parseContextAttribute.cpp parseContextAttributeObject
    ("/v2/entities", {"id": "r1", "a": {"value": 1, "unit": "m"}}, "unrecognized property for context attribute"),
    ("/v2/entities", {"id": "r1", "a": {"value": 1, "type": 5}}, "invalid JSON type for attribute type"),
    ("/v2/entities", {"id": "r1", "a": {"value": 1, "type": ""}}, "attribute type length: 0, min length supported: 1"),
    # jsonParseV2/parseMetadataVector.cpp and parseMetadata.cpp
    ("/v2/entities", {"id": "r1", "a": {"value": 1, "metadata": []}}, "metadata not a JSON object"),
    ("/v2/entities", {"id": "r1", "a": {"value": 1, "metadata": {"m": 1}}}, "metadata must be a JSON object"),
    ("/v2/entities", {"id": "r1", "a": {"value": 1, "metadata": {"m": {"value": 1, "x": 2}}}},
     "invalid JSON field for attribute metadata"),
    ("/v2/entities", {"id": "r1", "a": {"value": 1, "metadata": {"m": {"type": [], "value": 1}}}},
     "invalid JSON type for attribute metadata type"),
    # Entity::check (apiTypesV2/Entity.cpp) runs after the attributes are parsed
    ("/v2/entities", {"id": "r" * 257, "a": {"value": 1, "x": 1}}, "unrecognized property for context attribute"),
    ("/v2/entities", {"id": "r" * 257}, "entity id length: 257, max length supported: 256"),
    ("/v2/entities", {"id": "r1", "type": "a b"}, "Invalid characters in entity type"),
    ("/v2/op/update", {"actionType": "append", "entities": [{"id": ""}]},
     "id and idPattern cannot be both empty at the same time"),
])  # fmt: skip
def test_entity_payload_errors_have_orion_s_words(client: httpx.Client, path: str, body: dict, description: str) -> None:
    if path.endswith("/attrs"):
        assert client.post("/v2/entities", json={"id": "r1", "a": {"value": 1}}).status_code == 201
        for method in ("POST", "PATCH", "PUT"):  # parseEntity.cpp: membersFound == 0
            bad(client.request(method, path, json=body), description)
        assert client.get("/v2/entities/r1").json()["a"]["value"] == 1  # PUT {} did not drop the attributes
        return
    bad(client.post(path, json=body), description)
    assert client.get("/v2/entities").json() == []


@pytest.mark.parametrize("method, path", [("POST", "/v2/entities"), ("POST", "/v2/entities/r1/attrs"),
                                          ("PATCH", "/v2/entities/r1/attrs"), ("PUT", "/v2/entities/r1/attrs/a")])
def test_a_body_that_is_no_object_is_a_parse_error(client: httpx.Client, method: str, path: str) -> None:
    """parseEntity.cpp and parseContextAttribute.cpp: ``!document.IsObject()`` is ERROR_PARSE."""
    assert client.post("/v2/entities", json={"id": "r1", "a": {"value": 1}}).status_code == 201
    bad(client.request(method, path, json=[1]), "Errors found in incoming JSON buffer", "ParseError")


def test_compound_metadata_values_are_not_checked_for_forbidden_characters(client: httpx.Client) -> None:
    """Metadata::check (ngsi/Metadata.cpp) checks a metadata value only when it is a string; attribute
    values are checked however deep (CompoundValueNode::check)."""
    body = {"id": "r1", "a": {"value": 1, "metadata": {"m": {"value": {"note": "a<b"}}}}}
    assert client.post("/v2/entities", json=body).status_code == 201
    bad(client.post("/v2/entities", json={"id": "r2", "a": {"value": 1, "metadata": {"m": {"value": "a<b"}}}}),
        "Invalid characters in metadata value")


def test_text_unrestricted_metadata_lifts_the_check(client: httpx.Client) -> None:
    """ContextAttribute::check: a boolean metadata ``TextUnrestricted: true`` lifts the forbidden-character
    check as the type ``TextUnrestricted`` does."""
    body = {"id": "r1", "a": {"value": "a<b", "metadata": {"TextUnrestricted": {"value": True}}}}
    assert client.post("/v2/entities", json=body).status_code == 201
    assert client.get("/v2/entities/r1/attrs/a").json()["value"] == "a<b"


def _nested(levels: int) -> Any:
    value: Any = 1
    for _ in range(levels):
        value = {"v": value}
    return value


@pytest.mark.parametrize("where", ["value", "metadata"])
def test_values_nested_deeper_than_orion_s_limit_are_parse_errors(client: httpx.Client, where: str) -> None:
    """3605_killer_request_apiv2/killer_request_apiv2_deeply_nested_attr.test (and ..._metadata.test):
    400 ParseError "attribute or metadata value has overpassed maximum nesting limit: 50"; 51 levels of
    objects (depth 0 to 50, parseCompoundCommon.cpp ``deep > MAX_JSON_NESTING``) are fine."""
    def entity(entity_id: str, levels: int) -> dict[str, Any]:
        if where == "value":
            return {"id": entity_id, "a": {"value": _nested(levels)}}
        return {"id": entity_id, "a": {"value": 1, "metadata": {"m": {"value": _nested(levels)}}}}

    assert client.post("/v2/entities", json=entity("r1", 51)).status_code == 201
    bad(client.post("/v2/entities", json=entity("r2", 52)),
        "attribute or metadata value has overpassed maximum nesting limit: 50", "ParseError")
    bad(client.post("/v2/entities?options=keyValues", json={"id": "r3", "a": _nested(52)}),
        "attribute or metadata value has overpassed maximum nesting limit: 50", "ParseError")


def test_upsert_answers_204_when_it_creates_too(client: httpx.Client) -> None:
    """serviceRoutinesV2/postEntities.cpp: with ``options=upsert`` the success code is SccNoContent;
    functional test 3215_upsert_op/upsert_op_as_create.test step 01: 204 and ``Location``."""
    answer = client.post("/v2/entities?options=upsert", json={"id": "E", "type": "T", "A": {"value": 1}})
    assert (answer.status_code, answer.headers["Location"]) == (204, "/v2/entities/E?type=T")
    answer = client.post("/v2/entities?options=upsert", json={"id": "E", "type": "T", "B": {"value": 3}})
    assert (answer.status_code, answer.headers["Location"]) == (204, "/v2/entities/E?type=T")
    assert client.get("/v2/entities/E?options=keyValues").json() == {"id": "E", "type": "T", "A": 1, "B": 3}


# --- service paths and subscriptions ---------------------------------------------------------------------


def test_subscription_reads_filter_on_the_first_service_path(client: httpx.Client) -> None:
    """functional test 3945_servicepath_ignored_in_get_subs: a subscription made in another path is 404
    by id; lists filter on the header's first path unless it is ``/#`` (mongoGetSubscriptions.cpp)."""
    foo = created(client.post("/v2/subscriptions", json=subscription(), headers={"Fiware-ServicePath": "/foo"}))
    bar = created(client.post("/v2/subscriptions", json=subscription(), headers={"Fiware-ServicePath": "/bar"}))
    assert client.get(f"/v2/subscriptions/{foo}", headers={"Fiware-ServicePath": "/foo"}).status_code == 200
    bad(client.get(f"/v2/subscriptions/{bar}", headers={"Fiware-ServicePath": "/foo"}),
        "The requested subscription has not been found. Check id", "NotFound", 404)
    assert client.get(f"/v2/subscriptions/{bar}").status_code == 200
    listed = client.get("/v2/subscriptions", headers={"Fiware-ServicePath": "/foo,/bar"}).json()
    assert [s["id"] for s in listed] == [foo]
    assert [s["id"] for s in client.get("/v2/subscriptions", headers={"Fiware-ServicePath": "/#"}).json()] == [foo, bar]


def test_a_subscription_takes_one_service_path(client: httpx.Client) -> None:
    """serviceRoutinesV2/postSubscriptions.cpp: "max *one* service-path allowed for subscriptions (%lu given)"."""
    bad(client.post("/v2/subscriptions", json=subscription(), headers={"Fiware-ServicePath": "/a,/b"}),
        "max *one* service-path allowed for subscriptions (2 given)")


def test_patching_a_subscription_moves_it_to_the_patch_s_service_path(client: httpx.Client) -> None:
    """mongoBackend/mongoUpdateSubscription.cpp: ``setServicePath`` with the PATCH's own path (``/#``
    without the header) on every update."""
    sid = created(client.post("/v2/subscriptions", json=subscription(), headers={"Fiware-ServicePath": "/foo"}))
    assert client.patch(f"/v2/subscriptions/{sid}", json={"description": "moved"}).status_code == 204
    assert client.get(f"/v2/subscriptions/{sid}", headers={"Fiware-ServicePath": "/foo"}).status_code == 404
    assert client.get(f"/v2/subscriptions/{sid}", headers={"Fiware-ServicePath": "/#"}).json()["description"] == "moved"


# --- HTTP layer -------------------------------------------------------------------------------------------


@pytest.mark.parametrize("value, shown", [("Application/JSON", "Application/JSON"),
                                          ("application/json ;charset=utf-8", "application/json ")])
def test_content_type_is_compared_as_sent(client: httpx.Client, value: str, shown: str) -> None:
    """rest/rest.cpp: the header is cut at ``;`` and compared with ``!= "application/json"`` as is."""
    answer = client.post("/v2/entities", content=b'{"id": "r1"}', headers={"Content-Type": value})
    bad(answer, f"not supported content type: {shown}", "UnsupportedMediaType", 415)
    answer = client.post("/v2/entities", content=b'{"id": "r1"}', headers={"Content-Type": "application/json; charset=utf-8"})
    assert answer.status_code == 201


@pytest.mark.parametrize("text, value", [
    ("TRUE", True), ("False", False), ("NULL", None), ('"', ""), ("0x1A", 26), (" 7 ", 7), ("5.", 5),
])  # fmt: skip
def test_text_plain_values_read_as_orion_s_text_parse(client: httpx.Client, text: str, value: Any) -> None:
    """parse/textParse.cpp textParseAttributeValue: three spellings of each constant; a leading quote
    starts a string; numbers as C's ``strtod`` reads them (common/string.cpp str2double)."""
    assert client.post("/v2/entities", json={"id": "r1", "a": {"value": "x"}}).status_code == 201
    answer = client.put("/v2/entities/r1/attrs/a/value", content=text.encode(), headers={"Content-Type": "text/plain"})
    assert answer.status_code == 204, answer.text
    assert client.get("/v2/entities/r1/attrs/a").json()["value"] == value


@pytest.mark.parametrize("text, description", [
    ('"abc', "Missing citation-mark at end of string"),
    ("1_000", "attribute value type not recognized"),
    ("1e400", "attribute value type not recognized"),
    ("1e-400", "attribute value type not recognized"),
])
def test_text_plain_values_orion_refuses(client: httpx.Client, text: str, description: str) -> None:
    """textParse.cpp; str2double fails on text strtod leaves over and on ERANGE (over- and underflow)."""
    assert client.post("/v2/entities", json={"id": "r1", "a": {"value": "x"}}).status_code == 201
    bad(client.put("/v2/entities/r1/attrs/a/value", content=text.encode(), headers={"Content-Type": "text/plain"}),
        description)
    assert client.get("/v2/entities/r1/attrs/a").json()["value"] == "x"


# --- notifications ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("deleted, condition, notified", [
    ("B", ["B", "C"], True),   # 0000_subs_attrs_deletion/delete_attribute_in_condition.test
    ("B", [], True),           # 0000_subs_attrs_deletion/delete_attribute_in_empty_condition.test
    ("A", ["B", "C"], False),  # 0000_subs_attrs_deletion/delete_attribute_not_in_condition.test
])
@pytest.mark.parametrize("how", ["DELETE", "op/update"])
def test_deleting_an_attribute_notifies_as_a_change_of_it(client: httpx.Client, broker, deleted: str,
                                                         condition: list[str], notified: bool, how: str) -> None:
    """Orion's tests above: the notification carries the attributes left; timesSent counts it. An
    ``op/update`` ``delete`` naming attributes deletes them the same way."""
    listener = Listener()
    try:
        entity = {"id": "E1", "type": "T", "A": {"value": 1}, "B": {"value": 2}, "C": {"value": 3}}
        assert client.post("/v2/entities", json=entity).status_code == 201
        body = {"subject": {"entities": [{"idPattern": "E.*"}], "condition": {"attrs": condition}},
                "notification": {"http": {"url": listener.url}, "attrs": ["A", "B", "C"]}}
        sid = created(client.post("/v2/subscriptions", json=body))
        if how == "DELETE":
            answer = client.delete(f"/v2/entities/E1/attrs/{deleted}")
        else:
            answer = client.post("/v2/op/update", json={"actionType": "delete",
                                                        "entities": [{"id": "E1", "type": "T", deleted: {}}]})
        assert answer.status_code == 204
        assert broker.wait_notifications(timeout=10)
        got = [json.loads(n.body)["data"][0] for n in listener.take()]
        left = [name for name in "ABC" if name != deleted]
        assert [sorted(set(d) - {"id", "type"}) for d in got] == ([left] if notified else [])
        assert client.get(f"/v2/subscriptions/{sid}").json()["notification"].get("timesSent", 0) == int(notified)
    finally:
        listener.stop()


# --- batch failures ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("entities, answer", [
    # the first failure sets status and words, later ones are appended (OrionError::fillOrAppend), a
    # missing entity after the first without " - " (MongoCommonUpdate.cpp: ", " + enStr + " [entity itself]")
    ([{"id": "x1"}, {"id": "x2"}], (404, "NotFound", "do not exist: x1 - [entity itself], x2 [entity itself]")),
    # coverage: not found, then all attributes failed, stays a failure of the first kind (mongoUpdateContext.cpp)
    ([{"id": "x1"}, {"id": "r1", "nope": {"value": 1}}],
     (404, "NotFound", "do not exist: x1 - [entity itself], r1 - [ nope ]")),
    ([{"id": "r1", "nope": {"value": 1}}, {"id": "x1"}],
     (422, "Unprocessable", "do not exist: r1 - [ nope ], x1 [entity itself]")),
    # something applied: PartialUpdate, with the words of the first failure
    ([{"id": "x1"}, {"id": "r1", "a": {"value": 2}}],
     (422, "PartialUpdate", "do not exist: x1 - [entity itself]")),
])  # fmt: skip
def test_batch_failures_compose_as_orion_s(client: httpx.Client, entities: list, answer: tuple) -> None:
    assert client.post("/v2/entities", json={"id": "r1", "a": {"value": 1}}).status_code == 201
    got = client.post("/v2/op/update", json={"actionType": "update", "entities": entities})
    status, error, description = answer
    bad(got, description, error, status)


def test_too_long_an_entity_key_is_refused(client: httpx.Client) -> None:
    """functional test 1289_exceed_mongo_key_limit/exceed_mongo_key_limit.test: id and type of 255
    characters in a ten-level service path are 400 "Too long entity id/type/servicePath combination"
    (serviceRoutinesV2/postEntities.cpp legalEntityLength: the sum plus 10 must stay under 1024)."""
    path = "/" + "/".join(["12345678901234567890123456789012345678901234567890"] * 10) + "/"
    entity = {"id": "i" * 255, "type": "t" * 255, "temp": "29"}
    answer = client.post("/v2/entities?options=keyValues", json=entity, headers={"Fiware-ServicePath": path})
    bad(answer, "Too long entity id/type/servicePath combination")
    assert client.get("/v2/entities", headers={"Fiware-ServicePath": path[:-1]}).json() == []


def test_an_id_list_is_matched_as_orion_s_regex(client: httpx.Client) -> None:
    """serviceRoutinesV2/getEntities.cpp builds ``^id1$|^id2$`` from ``id=id1,id2`` and matches it as a
    pattern: a dot in an id matches any character."""
    for entity_id in ("robot.1", "robot_1", "robot_10"):
        assert client.post("/v2/entities", json={"id": entity_id}).status_code == 201
    assert [e["id"] for e in client.get("/v2/entities?id=robot.1").json()] == ["robot.1", "robot_1"]
    assert [e["id"] for e in client.get("/v2/entities?id=robot_10,robot.1").json()] == ["robot.1", "robot_1",
                                                                                       "robot_10"]


def test_repeated_type_parameters_add_up(client: httpx.Client) -> None:
    """rest/rest.cpp uriArgumentGet pushes every ``type`` into uriParamTypes (getEntities.cpp queries
    them all); other repeated parameters keep their last value (``ciP->uriParam[key] = value``)."""
    for entity_id, entity_type in (("r1", "A"), ("r2", "B"), ("r3", "C")):
        assert client.post("/v2/entities", json={"id": entity_id, "type": entity_type}).status_code == 201
    assert [e["id"] for e in client.get("/v2/entities?type=A&type=C").json()] == ["r1", "r3"]
    assert [e["id"] for e in client.get("/v2/entities?limit=1&limit=2").json()] == ["r1", "r2"]


def test_a_single_entity_read_takes_the_last_type(client: httpx.Client) -> None:
    """getEntity.cpp reads ``uriParam["type"]``, the last value given."""
    assert client.post("/v2/entities", json={"id": "r1", "type": "B"}).status_code == 201
    assert client.get("/v2/entities/r1?type=A&type=B").status_code == 200


# --- DateTime values ------------------------------------------------------------------------------------------

PARTIAL_DATES = ["2016-10-01", "2016-10-01T00", "2016-10-01T00Z", "2016-10-01T00:00", "2016-10-01T00:00Z",
                 "2016-10-01T00:00:00", "2016-10-01T00:00:00Z", "2016-10-01T00:00:00.000",
                 "2016-10-01T00:00:00.000Z", "2016-10-01T0000", "2016-10-01T0000Z", "2016-10-01T000000",
                 "2016-10-01T000000Z", "2016-10-01T000000.000", "2016-10-01T000000.000Z",
                 "2016-10-01T02:00:00+02:00", "2016-09-30T23:00:00-0100"]


def test_date_time_values_read_back_as_orion_prints_them(client: httpx.Client) -> None:
    """functional test 2631_partial_datetimes/partial_datetime_creation.test: every partial form reads
    back ``2016-10-01T00:00:00.000Z`` (parse8601Time, isodate2str); zones are applied (globals.cpp
    timezoneOffset); milliseconds are kept (1039_ngsiv2_date_support/basic_dates_support.test)."""
    entity: dict[str, Any] = {"id": "E", "type": "T"}
    entity |= {f"A{i}": {"value": text, "type": "DateTime"} for i, text in enumerate(PARTIAL_DATES)}
    entity["ms"] = {"value": "2050-04-05T14:00:00.123Z", "type": "DateTime",
                    "metadata": {"at": {"value": "2018-12-03T13:21:42.456Z", "type": "ISO8601"}}}
    entity["none"] = {"value": None, "type": "DateTime"}
    assert client.post("/v2/entities", json=entity).status_code == 201
    got = client.get("/v2/entities/E?options=keyValues").json()
    assert {got[f"A{i}"] for i in range(len(PARTIAL_DATES))} == {"2016-10-01T00:00:00.000Z"}
    assert (got["ms"], got["none"]) == ("2050-04-05T14:00:00.123Z", None)
    assert client.get("/v2/entities/E/attrs/ms").json()["metadata"]["at"]["value"] == "2018-12-03T13:21:42.456Z"


@pytest.mark.parametrize("attribute, description", [
    ({"value": "foo", "type": "DateTime"}, "date has invalid format in attribute value"),
    ({"value": 5, "type": "DateTime"}, "date has invalid format in attribute value"),
    ({"value": "2016-02-30T00:00:00Z", "type": "DateTime"}, "date has invalid format in attribute value"),
    ({"value": "2016-10-01Z", "type": "DateTime"}, "date has invalid format in attribute value"),
    ({"value": 1, "metadata": {"at": {"value": "bar", "type": "DateTime"}}}, "date has invalid format in metadata value"),
])  # fmt: skip
def test_date_time_values_orion_refuses(client: httpx.Client, attribute: dict, description: str) -> None:
    """parseContextAttribute.cpp and parseMetadata.cpp: parse8601Time answering -1 is refused (1039 step 01)."""
    bad(client.post("/v2/entities", json={"id": "E", "A": attribute}), description)
    assert client.get("/v2/entities").json() == []


@pytest.mark.parametrize("value", [{"$inc": 1}, {"$push": 3, "x": 1}, {"$max": "2020-01-01T00:00:00Z"}])
def test_update_operators_are_not_stored_as_values(client: httpx.Client, value: Any) -> None:
    """Orion applies an object value whose first key is an update operator (mongoBackend/dbConstants.h
    UPDATE_OPERATORS_ALL, ngsi/ContextAttribute.cpp); this broker says it does not, rather than store it."""
    assert client.post("/v2/entities", json={"id": "E", "A": {"value": 1}}).status_code == 201
    answer = client.patch("/v2/entities/E/attrs", json={"A": {"value": value, "type": "DateTime"}})
    assert (answer.status_code, answer.json()["error"]) == (501, "NotImplemented")
    answer = client.patch("/v2/entities/E/attrs?options=keyValues", json={"A": value})
    assert (answer.status_code, answer.json()["error"]) == (501, "NotImplemented")
    assert client.get("/v2/entities/E/attrs/A/value").json() == 1


def test_a_date_time_value_reads_as_text_without_quotes(client: httpx.Client) -> None:
    """ngsi/ContextAttribute.cpp: a DateTime value is a number printed by isodate2str, so ``GET .../value``
    as text gives it bare; a string (``PUT .../value`` stores text as written) keeps its quotes."""
    assert client.post("/v2/entities", json={"id": "E", "A": {"value": "2016-10-01", "type": "DateTime"}}).status_code == 201
    assert client.get("/v2/entities/E/attrs/A/value").content == b"2016-10-01T00:00:00.000Z"
    answer = client.put("/v2/entities/E/attrs/A/value", content=b'"2016-10-01"', headers={"Content-Type": "text/plain"})
    assert answer.status_code == 204
    assert client.get("/v2/entities/E/attrs/A/value").content == b'"2016-10-01"'


def test_repeated_options_add_up(client: httpx.Client) -> None:
    """rest/ConnectionInfo.cpp uriParamOptionsParse sets every option of every ``options`` parameter in
    one map, and checks the forbidden pairs on it."""
    assert client.post("/v2/entities", json={"id": "E", "A": {"value": 1}}).status_code == 201
    answer = client.get("/v2/entities?options=count&options=keyValues")
    assert (answer.json(), answer.headers["Fiware-Total-Count"]) == ([{"id": "E", "type": "Thing", "A": 1}], "1")
    bad(client.get("/v2/entities?options=keyValues&options=values"), "Invalid value for URI param /options/")
