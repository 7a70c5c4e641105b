"""The broker engine without sockets: behaviour vcran relies on beyond what the Orion recording covers
(batches split over several requests, tenants, service paths, subscriptions on id lists, what a
notification carries) and the HTTP-level rules the engine decides from headers."""

from __future__ import annotations

import json
import random
from typing import Any

import pytest

from tests.conftest import HandClock
from vcran.broker import Broker, Outcome, Request

URL = "http://127.0.0.1:9/notify"


@pytest.fixture
def broker() -> Broker:
    return Broker(clock=HandClock(1_700_000_000.0), rng=random.Random(7))


def call(broker: Broker, method: str, target: str, body: Any = None, **headers: str) -> Outcome:
    return broker.handle(Request.make(method, target, body, {k.replace("_", "-"): v for k, v in headers.items()}))


def ok(outcome: Outcome, status: int = 204) -> Outcome:
    assert outcome.response.status == status, outcome.response.body
    return outcome


def error(outcome: Outcome, status: int, name: str, description: str | None = None) -> None:
    assert outcome.response.status == status
    body = outcome.response.json()
    assert body["error"] == name
    if description is not None:
        assert body["description"] == description


def robot(entity_id: str, **attrs: Any) -> dict[str, Any]:
    return {"id": entity_id, "type": "ROBOT", **{k: {"type": "Number", "value": v} for k, v in attrs.items()}}


def subscribe(broker: Broker, body: dict[str, Any] | None = None, **headers: str) -> str:
    body = body or {
        "subject": {"entities": [{"idPattern": ".*", "type": "ROBOT"}]},
        "notification": {"http": {"url": URL}},
    }
    location = ok(call(broker, "POST", "/v2/subscriptions", body, **headers), 201).response.header("Location")
    assert location is not None
    return location.rsplit("/", 1)[1]


def data(outcome: Outcome) -> list[dict[str, Any]]:
    """The entities notified, one per notification, in order."""
    return [entity for n in outcome.notifications for entity in n.json()["data"]]


# --- op/update: batches that vcran sends, over several requests ----------------------------------------


def test_op_update_append_over_successive_batches_creates_then_updates(broker: Broker) -> None:
    batch = {"actionType": "append", "entities": [robot("r1", battery=1), robot("r2", battery=2)]}
    ok(call(broker, "POST", "/v2/op/update", batch))
    batch = {"actionType": "append", "entities": [robot("r2", battery=3, speed=1), robot("r3", battery=4)]}
    ok(call(broker, "POST", "/v2/op/update", batch))
    listed = ok(call(broker, "GET", "/v2/entities?options=keyValues"), 200).response.json()
    assert listed == [
        {"id": "r1", "type": "ROBOT", "battery": 1},
        {"id": "r2", "type": "ROBOT", "battery": 3, "speed": 1},
        {"id": "r3", "type": "ROBOT", "battery": 4},
    ]


def test_op_update_append_strict_adds_new_attributes_and_reports_existing(broker: Broker) -> None:
    ok(call(broker, "POST", "/v2/entities", robot("r1", battery=1)), 201)
    batch = {"actionType": "appendStrict", "entities": [robot("r1", battery=5, speed=2)]}
    error(
        call(broker, "POST", "/v2/op/update", batch),
        422,
        "PartialUpdate",
        "one or more of the attributes in the request already exist: r1/ROBOT - [ battery ]",
    )
    got = call(broker, "GET", "/v2/entities/r1?options=keyValues").response.json()
    assert got == {"id": "r1", "type": "ROBOT", "battery": 1, "speed": 2}


def test_op_update_update_with_a_missing_attribute_updates_the_rest(broker: Broker) -> None:
    ok(call(broker, "POST", "/v2/entities", robot("r1", battery=1)), 201)
    batch = {"actionType": "update", "entities": [robot("r1", battery=9, nope=1)]}
    error(call(broker, "POST", "/v2/op/update", batch), 422, "PartialUpdate", "do not exist: r1/ROBOT - [ nope ]")
    assert call(broker, "GET", "/v2/entities/r1/attrs/battery/value").response.body == b"9"


def test_op_update_delete_removes_attributes_or_whole_entities(broker: Broker) -> None:
    batch = {"actionType": "append", "entities": [robot("r1", a=1, b=2), robot("r2", a=1)]}
    ok(call(broker, "POST", "/v2/op/update", batch))
    batch = {
        "actionType": "delete",
        "entities": [{"id": "r1", "type": "ROBOT", "a": {}}, {"id": "r2", "type": "ROBOT"}],
    }
    ok(call(broker, "POST", "/v2/op/update", batch))
    assert call(broker, "GET", "/v2/entities?options=keyValues").response.json() == [
        {"id": "r1", "type": "ROBOT", "b": 2}
    ]


def test_op_update_replace_drops_attributes_not_given(broker: Broker) -> None:
    ok(call(broker, "POST", "/v2/entities", robot("r1", a=1, b=2)), 201)
    ok(call(broker, "POST", "/v2/op/update", {"actionType": "replace", "entities": [robot("r1", c=3)]}))
    assert call(broker, "GET", "/v2/entities/r1?options=keyValues").response.json() == {
        "id": "r1", "type": "ROBOT", "c": 3
    }  # fmt: skip


def test_op_update_rejects_the_whole_batch_on_one_bad_attribute_value(broker: Broker) -> None:
    batch = {"actionType": "append", "entities": [robot("r1", a=1), {"id": "r2", "note": {"value": "a;b"}}]}
    error(call(broker, "POST", "/v2/op/update", batch), 400, "BadRequest", "Invalid characters in attribute value")
    assert call(broker, "GET", "/v2/entities").response.json() == []


def test_op_update_key_values_option(broker: Broker) -> None:
    batch = {"actionType": "append", "entities": [{"id": "r1", "type": "ROBOT", "battery": 50, "state": "IDLE"}]}
    ok(call(broker, "POST", "/v2/op/update?options=keyValues", batch))
    got = call(broker, "GET", "/v2/entities/r1").response.json()
    assert got["battery"] == {"type": "Number", "value": 50, "metadata": {}}
    assert got["state"] == {"type": "Text", "value": "IDLE", "metadata": {}}


@pytest.mark.parametrize(
    "body, description",
    [
        ({"entities": [robot("r1")]}, "Invalid JSON payload, mandatory field /actionType/ not found"),
        ({"actionType": "upsert", "entities": [robot("r1")]}, None),
        ({"actionType": "append", "entities": []}, "empty entities vector"),
    ],
)
def test_op_update_payload_errors(broker: Broker, body: dict[str, Any], description: str | None) -> None:
    error(call(broker, "POST", "/v2/op/update", body), 400, "BadRequest", description)


def test_op_query_selects_by_entities_and_projects_attrs(broker: Broker) -> None:
    batch = {"actionType": "append", "entities": [robot("r1", a=1, b=2), robot("r2", a=3), robot("x9", a=4)]}
    ok(call(broker, "POST", "/v2/op/update", batch))
    query = {"entities": [{"idPattern": "r.*", "type": "ROBOT"}], "attrs": ["b", "a"]}
    got = ok(call(broker, "POST", "/v2/op/query?options=keyValues", query), 200).response.json()
    assert got == [{"id": "r1", "type": "ROBOT", "b": 2, "a": 1}, {"id": "r2", "type": "ROBOT", "a": 3}]


# --- tenants and service paths -----------------------------------------------------------------------


def test_tenants_are_isolated_and_case_insensitive(broker: Broker) -> None:
    ok(call(broker, "POST", "/v2/entities", robot("r1", a=1), Fiware_Service="Plant_A"), 201)
    ok(call(broker, "POST", "/v2/entities", robot("r1", a=2), Fiware_Service="plant_b"), 201)
    assert call(broker, "GET", "/v2/entities/r1/attrs/a/value", Fiware_Service="PLANT_A").response.body == b"1"
    assert call(broker, "GET", "/v2/entities/r1/attrs/a/value", Fiware_Service="plant_b").response.body == b"2"
    assert call(broker, "GET", "/v2/entities").response.json() == []


def test_subscription_only_sees_its_own_tenant(broker: Broker) -> None:
    subscribe(broker, Fiware_Service="plant_a")
    assert call(broker, "POST", "/v2/entities", robot("r1", a=1)).notifications == ()
    notified = call(broker, "POST", "/v2/entities", robot("r1", a=1), Fiware_Service="plant_a").notifications
    assert [n.header("Fiware-Service") for n in notified] == ["plant_a"]


@pytest.mark.parametrize(
    "path, visible",
    [
        ("/", ["root"]),
        ("/a", ["ra"]),
        ("/a/#", ["ra", "rab"]),
        ("/a/b", ["rab"]),
        ("/#", ["root", "ra", "rab"]),
        ("/a, /a/b", ["ra", "rab"]),
        (None, ["root", "ra", "rab"]),
    ],
)
def test_queries_see_exactly_their_service_paths(broker: Broker, path: str | None, visible: list[str]) -> None:
    ok(call(broker, "POST", "/v2/entities", robot("root")), 201)
    ok(call(broker, "POST", "/v2/entities", robot("ra"), Fiware_ServicePath="/a"), 201)
    ok(call(broker, "POST", "/v2/entities", robot("rab"), Fiware_ServicePath="/a/b"), 201)
    headers = {} if path is None else {"Fiware_ServicePath": path}
    listed = ok(call(broker, "GET", "/v2/entities", **headers), 200).response.json()
    assert [e["id"] for e in listed] == visible


def test_writes_without_service_path_find_entities_only_in_the_root_path(broker: Broker) -> None:
    """Orion's postUpdateContext.cpp writes in ``/`` when the header is absent: functional test
    3640_PATCH_update_with_wrong_servicepath step 09 answers 404 for an entity in ``/Level_1``."""
    ok(call(broker, "POST", "/v2/entities", robot("r1", a=1), Fiware_ServicePath="/a"), 201)
    error(call(broker, "PATCH", "/v2/entities/r1/attrs", {"a": {"value": 2}}), 404, "NotFound")
    error(call(broker, "PATCH", "/v2/entities/r1/attrs", {"a": {"value": 3}}, Fiware_ServicePath="/b"), 404, "NotFound")
    error(call(broker, "DELETE", "/v2/entities/r1"), 404, "NotFound")
    subscribe(broker, Fiware_ServicePath="/a/#")
    notified = call(broker, "PATCH", "/v2/entities/r1/attrs", {"a": {"value": 4}}, Fiware_ServicePath="/a").notifications
    assert [n.header("Fiware-Servicepath") for n in notified] == ["/a"]


@pytest.mark.parametrize(
    "headers, description",
    [
        ({"Fiware_ServicePath": "/a/b#"}, "a component of ServicePath contains an illegal character"),
        ({"Fiware_ServicePath": "/a//b"}, "empty component in ServicePath"),
        ({"Fiware_ServicePath": "/" + "x" * 51}, "component-name too long in ServicePath"),
        ({"Fiware_ServicePath": "/a" * 11}, "too many components in ServicePath"),
        ({"Fiware_Service": "plant a"}, None),
    ],
)
def test_bad_scope_headers(broker: Broker, headers: dict[str, str], description: str | None) -> None:
    error(call(broker, "GET", "/v2/entities", **headers), 400, "BadRequest", description)


@pytest.mark.parametrize("method, target, path, description", [
    # serviceRoutinesV2/postUpdateContext.cpp and common/string.cpp servicePathCheck
    ("POST", "/v2/entities", "/a,/b", "more than one service path in context update request"),
    ("POST", "/v2/entities", "/a/#", "Bad Character in Service-Path"),
    # rest/rest.cpp servicePathCheck; functional tests 3640_PATCH_update_with_wrong_servicepath (steps 07,
    # 08) and 3071_DELETE_with_wrong_servicepath (steps 05, 06)
    ("PATCH", "/v2/entities/r1/attrs", "/#", "servicepath with wildcard # is not allowed in patch update request"),
    ("PATCH", "/v2/entities/r1/attrs", "/a, /b", "more than one servicepath in patch update request is not allowed"),
    ("DELETE", "/v2/entities/r1", "/#", "servicepath with wildcard # is not allowed in DELETE operation"),
    ("DELETE", "/v2/entities/r1", "/a,/b", "more than one servicepath is not allowed in DELETE operation"),
])  # fmt: skip
def test_a_write_names_one_plain_service_path(broker: Broker, method: str, target: str, path: str,
                                              description: str) -> None:
    body = robot("r1") if method == "POST" else {"a": {"value": 1}} if method == "PATCH" else None
    error(call(broker, method, target, body, Fiware_ServicePath=path), 400, "BadRequest", description)


# --- subscriptions and notifications ---------------------------------------------------------------------


def test_subscription_on_a_list_of_entity_ids(broker: Broker) -> None:
    subscribe(
        broker,
        {
            "subject": {"entities": [{"id": "r1", "type": "ROBOT"}, {"id": "r2", "type": "ROBOT"}]},
            "notification": {"http": {"url": URL}},
        },
    )
    batch = {"actionType": "append", "entities": [robot("r1", a=1), robot("r2", a=1), robot("r3", a=1)]}
    outcome = ok(call(broker, "POST", "/v2/op/update", batch))
    assert [e["id"] for e in data(outcome)] == ["r1", "r2"]
    assert [n.header("Fiware-Correlator").rsplit("; ", 1)[1] for n in outcome.notifications] == [
        "cbnotif=1", "cbnotif=2"
    ]  # fmt: skip


def test_notification_carries_the_subscribed_attributes_in_subscription_order(broker: Broker) -> None:
    ok(call(broker, "POST", "/v2/entities", robot("r1", a=1, b=2, c=3)), 201)
    subscribe(
        broker,
        {
            "subject": {"entities": [{"id": "r1"}], "condition": {"attrs": ["a"]}},
            "notification": {"http": {"url": URL}, "attrs": ["c", "a", "missing"]},
        },
    )
    assert call(broker, "PATCH", "/v2/entities/r1/attrs", {"b": {"value": 5}}).notifications == ()
    outcome = call(broker, "PATCH", "/v2/entities/r1/attrs", {"a": {"value": 5}})
    assert json.dumps(data(outcome)) == json.dumps(
        [
            {
                "id": "r1",
                "type": "ROBOT",
                "c": {"type": "Number", "value": 3, "metadata": {}},
                "a": {"type": "Number", "value": 5, "metadata": {}},
            }
        ]
    )


def test_empty_condition_and_attrs_mean_any_change_and_every_attribute(broker: Broker) -> None:
    subscribe(broker)
    ok(call(broker, "POST", "/v2/entities", robot("r1", a=1, b=2)), 201)  # creation notifies too
    outcome = call(broker, "PATCH", "/v2/entities/r1/attrs", {"b": {"value": 3}})
    assert list(data(outcome)[0]) == ["id", "type", "a", "b"]


def test_except_attrs_only_changed_attrs_and_key_values(broker: Broker) -> None:
    ok(call(broker, "POST", "/v2/entities", robot("r1", a=1, b=2, c=3)), 201)
    subscribe(
        broker,
        {
            "subject": {"entities": [{"id": "r1"}]},
            "notification": {
                "http": {"url": URL},
                "exceptAttrs": ["c"],
                "onlyChangedAttrs": True,
                "attrsFormat": "keyValues",
            },
        },
    )
    outcome = call(broker, "PATCH", "/v2/entities/r1/attrs", {"b": {"value": 7}, "c": {"value": 7}})
    assert data(outcome) == [{"id": "r1", "type": "ROBOT", "b": 7}]
    assert outcome.notifications[0].header("Ngsiv2-AttrsFormat") == "keyValues"


def test_metadata_changes_notify_unless_the_subscription_says_otherwise(broker: Broker) -> None:
    ok(call(broker, "POST", "/v2/entities", robot("r1", a=1)), 201)
    quiet = {
        "subject": {"entities": [{"id": "r1"}], "condition": {"attrs": [], "notifyOnMetadataChange": False}},
        "notification": {"http": {"url": URL}},
    }
    loud = subscribe(broker)
    subscribe(broker, quiet)
    patch = {"a": {"type": "Number", "value": 1, "metadata": {"unit": {"value": "%"}}}}
    outcome = call(broker, "PATCH", "/v2/entities/r1/attrs", patch)
    assert [n.subscription_id for n in outcome.notifications] == [loud]


def test_type_change_notifies_and_same_value_does_not(broker: Broker) -> None:
    ok(call(broker, "POST", "/v2/entities", robot("r1", a=1)), 201)
    subscribe(broker)
    assert call(broker, "PATCH", "/v2/entities/r1/attrs", {"a": {"type": "Number", "value": 1.0}}).notifications == ()
    assert (
        len(call(broker, "PATCH", "/v2/entities/r1/attrs", {"a": {"type": "Integer", "value": 1}}).notifications) == 1
    )


def test_forced_update_notifies_without_a_change(broker: Broker) -> None:
    ok(call(broker, "POST", "/v2/entities", robot("r1", a=1)), 201)
    subscribe(broker)
    outcome = call(
        broker, "POST", "/v2/op/update?options=forcedUpdate", {"actionType": "update", "entities": [robot("r1", a=1)]}
    )
    assert len(outcome.notifications) == 1


def test_entity_deletes_and_inactive_subscriptions_do_not_notify(broker: Broker) -> None:
    """An attribute's deletion notifies with the attributes left (functional test
    3956_delete_attribute_notif_fail); an entity's deletion does not (default alterationTypes
    ``entityCreate, entityChange``, orion-api.md)."""
    ok(call(broker, "POST", "/v2/entities", robot("r1", a=1, b=1)), 201)
    subscription = subscribe(broker)
    notified = call(broker, "DELETE", "/v2/entities/r1/attrs/b").notifications
    assert [n.json()["data"][0] for n in notified] == [{"id": "r1", "type": "ROBOT",
                                                         "a": {"type": "Number", "value": 1, "metadata": {}}}]
    ok(call(broker, "PATCH", f"/v2/subscriptions/{subscription}", {"status": "inactive"}))
    assert call(broker, "PATCH", "/v2/entities/r1/attrs", {"a": {"value": 2}}).notifications == ()
    assert call(broker, "DELETE", "/v2/entities/r1").notifications == ()


def test_notification_correlator_follows_the_request(broker: Broker) -> None:
    subscribe(broker)
    outcome = call(broker, "POST", "/v2/entities", robot("r1", a=1), Fiware_Correlator="abc")
    assert outcome.response.header("Fiware-Correlator") == "abc"
    assert outcome.notifications[0].header("Fiware-Correlator") == "abc; cbnotif=1"


def test_delivery_record_failure_then_success(broker: Broker) -> None:
    """Orion 4.7 keeps the status ``active`` and counts failures in ``failsCounter`` (``failed`` was
    dropped in 3.4.0: orion-api.md "Ambiguous subscription status failed not used"; functional test
    1960_failure_stats_in_db_and_notifications/failure_stats_in_db_and_notifications.test, step 03).
    Times are whole seconds (cache/subCache.h keeps int64_t), so they end in ``.000Z``."""
    subscription = subscribe(broker)
    notified = call(broker, "POST", "/v2/entities", robot("r1", a=1)).notifications
    broker.delivery_result(notified[0], None, "Couldn't connect to server")
    shown = call(broker, "GET", f"/v2/subscriptions/{subscription}").response.json()
    assert shown["status"] == "active"
    assert shown["notification"]["timesSent"] == 1
    assert shown["notification"]["failsCounter"] == 1
    assert shown["notification"]["lastFailureReason"] == "Couldn't connect to server"
    assert shown["notification"]["lastFailure"] == "2023-11-14T22:13:20.000Z"
    assert shown["notification"]["lastNotification"] == "2023-11-14T22:13:20.000Z"
    broker.delivery_result(notified[0], 404)
    shown = call(broker, "GET", f"/v2/subscriptions/{subscription}").response.json()
    assert (shown["status"], shown["notification"]["lastSuccessCode"]) == ("active", 404)
    assert "failsCounter" not in shown["notification"]


def test_subscription_list_count_and_deterministic_ids() -> None:
    def ids() -> list[str]:
        broker = Broker(clock=HandClock(1_700_000_000.0), rng=random.Random(1))
        return [subscribe(broker) for _ in range(3)]

    first = ids()
    assert first == ids() and len(set(first)) == 3 and all(len(i) == 24 for i in first)
    broker = Broker(clock=HandClock(1_700_000_000.0), rng=random.Random(1))
    for _ in range(3):
        subscribe(broker)
    listed = call(broker, "GET", "/v2/subscriptions?options=count&limit=2")
    assert listed.response.header("Fiware-Total-Count") == "3"
    assert len(listed.response.json()) == 2


@pytest.mark.parametrize(
    "body, description",
    [
        ({"notification": {"http": {"url": URL}}}, "no subject for subscription specified"),
        ({"subject": {"entities": [{"id": "r1"}]}}, "no notification for subscription specified"),
        (
            {"subject": {"entities": [{"id": "r1"}]}, "notification": {"http": {"url": "ftp://x"}}},
            "Invalid URL parsing notification url",
        ),
        (
            {"subject": {"entities": [{"idPattern": "("}]}, "notification": {"http": {"url": URL}}},
            "Invalid regex for entity idPattern",
        ),
    ],
)
def test_subscription_payload_errors(broker: Broker, body: dict[str, Any], description: str) -> None:
    error(call(broker, "POST", "/v2/subscriptions", body), 400, "BadRequest", description)


# --- HTTP-level rules ---------------------------------------------------------------------------------


def test_http_layer_errors_from_headers_alone(broker: Broker) -> None:
    big = Request("POST", "/v2/entities", (("Content-Length", "2000000"), ("Content-Type", "application/json")))
    error(broker.handle(big), 413, "RequestEntityTooLarge", "payload size: 2000000, max size supported: 1048576")
    chunked = Request("POST", "/v2/entities", (("Transfer-Encoding", "chunked"),), b"")
    error(broker.handle(chunked), 411, "ContentLengthRequired")
    error(call(broker, "DELETE", "/v2/op/update"), 405, "MethodNotAllowed", "method not allowed")
    assert call(broker, "DELETE", "/v2/op/update").response.header("Allow") == "POST"
    error(call(broker, "GET", "/v2/entities", Accept="text/html"), 406, "NotAcceptable")


@pytest.mark.parametrize(
    "target, status, description",
    [
        ("/v2/entities?options=nope", 400, "Invalid value for URI param /options/"),
        ("/v2/entities?limit=x", 400, "Bad pagination limit: /x/ [must be a positive integer number]"),
        ("/v2/entities?limit=-1", 400, "Bad pagination limit: /-1/ [must be a positive integer number]"),
        ("/v2/entities?offset=x", 400, "Bad pagination offset: /x/ [must be a decimal number]"),
        ("/v2/entities?limit=1001", 400, "Bad pagination limit: /1001/ [max: 1000]"),
        ("/v2/entities?attrs=", 400, "Empty right-hand-side for URI param /attrs/"),
        ("/v2/entities?type=a%3Cb", 400, "invalid character in URI parameter"),
        ("/v2/entities?q=a>1", 501, "vcran broker does not implement the URI parameter 'q'"),
        ("/v2/types", 501, "vcran broker does not implement entity types"),
    ],
)
def test_uri_parameter_errors(broker: Broker, target: str, status: int, description: str) -> None:
    outcome = call(broker, "GET", target)
    assert (outcome.response.status, outcome.response.json()["description"]) == (status, description)


def test_scalar_values_read_as_text_and_write_from_text(broker: Broker) -> None:
    ok(call(broker, "POST", "/v2/entities", {"id": "r1", "note": {"value": "hi"}}), 201)
    got = call(broker, "GET", "/v2/entities/r1/attrs/note/value").response
    assert (got.header("Content-Type"), got.body) == ("text/plain", b'"hi"')
    error(call(broker, "GET", "/v2/entities/r1/attrs/note/value", Accept="application/json"), 406, "NotAcceptable")
    put = Request.make("PUT", "/v2/entities/r1/attrs/note/value", b"42", {"Content-Type": "text/plain"})
    ok(broker.handle(put))
    assert call(broker, "GET", "/v2/entities/r1/attrs/note").response.json() == {
        "type": "Text", "value": 42, "metadata": {}
    }  # fmt: skip


def test_upsert_and_metadata_merge(broker: Broker) -> None:
    first = {"id": "r1", "a": {"value": 1, "metadata": {"unit": {"value": "m"}}}}
    ok(call(broker, "POST", "/v2/entities", first), 201)
    again = {"id": "r1", "a": {"value": 2, "metadata": {"accuracy": {"value": 0.5}}}}
    ok(call(broker, "POST", "/v2/entities?options=upsert", again))
    got = call(broker, "GET", "/v2/entities/r1/attrs/a").response.json()
    assert got["metadata"] == {"unit": {"type": "Text", "value": "m"}, "accuracy": {"type": "Number", "value": 0.5}}
    ok(call(broker, "PATCH", "/v2/entities/r1/attrs?options=overrideMetadata", {"a": {"value": 3, "metadata": {}}}))
    assert call(broker, "GET", "/v2/entities/r1/attrs/a").response.json()["metadata"] == {}


def test_same_id_two_types_is_ambiguous_without_type(broker: Broker) -> None:
    ok(call(broker, "POST", "/v2/entities", {"id": "r1", "type": "A"}), 201)
    ok(call(broker, "POST", "/v2/entities", {"id": "r1", "type": "B"}), 201)
    error(call(broker, "GET", "/v2/entities/r1"), 409, "TooManyResults")
    assert ok(call(broker, "GET", "/v2/entities/r1?type=B"), 200).response.json() == {"id": "r1", "type": "B"}


def test_default_types_and_text_unrestricted(broker: Broker) -> None:
    entity = {
        "id": "r1",
        "flag": {"value": True},
        "nothing": {"value": None},
        "pose": {"value": [1, 2]},
        "html": {"type": "TextUnrestricted", "value": "<b>"},
    }
    ok(call(broker, "POST", "/v2/entities", entity), 201)
    got = call(broker, "GET", "/v2/entities/r1").response.json()
    assert [got[name]["type"] for name in ("flag", "nothing", "pose", "html")] == [
        "Boolean",
        "None",
        "StructuredValue",
        "TextUnrestricted",
    ]
    error(call(broker, "POST", "/v2/entities", {"id": "r2", "html": {"value": "<b>"}}), 400, "BadRequest")


def test_true_is_not_one(broker: Broker) -> None:
    ok(call(broker, "POST", "/v2/entities", {"id": "r1", "a": {"type": "X", "value": 1}}), 201)
    subscribe(broker, {"subject": {"entities": [{"id": "r1"}]}, "notification": {"http": {"url": URL}}})
    assert len(call(broker, "PATCH", "/v2/entities/r1/attrs", {"a": {"type": "X", "value": True}}).notifications) == 1


def test_values_format(broker: Broker) -> None:
    ok(call(broker, "POST", "/v2/entities", robot("r1", a=1, b=2)), 201)
    assert call(broker, "GET", "/v2/entities/r1?options=values&attrs=b,a").response.json() == [2, 1]
    assert call(broker, "GET", "/v2/entities?options=values").response.json() == [[1, 2]]


def test_oneshot_and_expired_subscriptions() -> None:
    clock = HandClock(1_700_000_000.0)
    broker = Broker(clock=clock, rng=random.Random(3))
    body = {"subject": {"entities": [{"id": "r1"}]}, "notification": {"http": {"url": URL}}}
    oneshot = subscribe(broker, {**body, "status": "oneshot"})
    expiring = subscribe(broker, {**body, "expires": "2023-11-14T22:14:00.000Z"})  # clock: 22:13:20
    assert len(call(broker, "POST", "/v2/entities", robot("r1", a=1)).notifications) == 2
    clock.now += 60
    notified = call(broker, "PATCH", "/v2/entities/r1/attrs", {"a": {"value": 2}}).notifications
    assert notified == ()
    assert call(broker, "GET", f"/v2/subscriptions/{oneshot}").response.json()["status"] == "inactive"
    assert call(broker, "GET", f"/v2/subscriptions/{expiring}").response.json()["status"] == "expired"


@pytest.mark.parametrize("body", [b'{"id": "r1"', b'{"id": NaN}', b"[" * 100_000, b'{"id": "\xff"}'])
def test_unparsable_bodies_are_parse_errors(broker: Broker, body: bytes) -> None:
    error(call(broker, "POST", "/v2/entities", body), 400, "ParseError", "Errors found in incoming JSON buffer")


def test_the_engine_imports_neither_sockets_nor_httpx() -> None:
    import subprocess
    import sys

    code = "import sys, vcran.broker; print(sorted({'httpx', 'http.server', 'socket'} & set(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_throttling_skips_notifications_within_its_seconds() -> None:
    """Orion's "Check 1: timing" (mongoBackend/MongoCommonUpdate.cpp): with ``throttling: N`` nothing is
    sent while ``N > now - lastNotification``, in whole seconds; a skipped change is not sent later."""
    clock = HandClock(1_700_000_000.5)
    broker = Broker(clock=clock, rng=random.Random(3))
    subscribe(broker, {"subject": {"entities": [{"id": "r1"}]}, "notification": {"http": {"url": URL}},
                       "throttling": 5})
    assert len(call(broker, "POST", "/v2/entities", robot("r1", a=1)).notifications) == 1
    clock.now += 4.4  # 1_700_000_004.9: four whole seconds later
    assert call(broker, "PATCH", "/v2/entities/r1/attrs", {"a": {"value": 2}}).notifications == ()
    clock.now += 0.2  # 1_700_000_005.1: five whole seconds after the last notification
    assert len(call(broker, "PATCH", "/v2/entities/r1/attrs", {"a": {"value": 3}}).notifications) == 1
    assert call(broker, "PATCH", "/v2/entities/r1/attrs", {"a": {"value": 4}}).notifications == ()
