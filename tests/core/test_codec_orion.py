"""Everything the codec sends is accepted by Orion: identifiers, forbidden characters, request size (docs/contract.md §2).

``orion_objections`` is a validator of Orion's syntax rules, calibrated below against the answers of a
real Orion 4.7 to the recorded ``POST /v2/entities`` requests; the encoder's output must pass it.
"""

from __future__ import annotations

import json
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tests.conftest import DATA
from vcran.core.opil.codec import (
    CodecError,
    encode_attribute,
    encode_entity,
    encode_entity_json,
    split_batch,
)
from vcran.core.opil.ids import id_for
from vcran.core.opil.messages import ATTRIBUTES, Motion, RanError
from vcran.core.opil.schema import Message
from vcran.core.orion_rules import MAX_REQUEST_BYTES, has_forbidden_chars, identifier_error
from vcran.testing.strategies import attribute_messages

EXCHANGES = [json.loads(line) for line in (DATA / "orion-4.7-exchanges.jsonl").read_text().splitlines()]


def compact(value: Any) -> bytes:
    return json.dumps(value, separators=(",", ":")).encode()


def orion_objections(entity: dict[str, Any]) -> list[str]:
    """What Orion would object to in ``POST /v2/entities`` with this entity (empty: accepted)."""
    problems = [identifier_error("entity id", entity.get("id"))]
    if "type" in entity:  # Orion defaults a missing type to Thing
        problems.append(identifier_error("entity type", entity["type"]))
    for name, attr in entity.items():
        if name in ("id", "type"):
            continue
        problems.append(identifier_error("attribute name", name))
        if "type" in attr:
            problems.append(identifier_error("attribute type", attr["type"]))
        for meta_name, meta in attr.get("metadata", {}).items():
            problems += [identifier_error("metadata name", meta_name), identifier_error("metadata type", meta["type"])]
        if has_forbidden_chars(attr.get("value")) or has_forbidden_chars(attr.get("metadata")):
            problems.append(f"forbidden characters in {name}")
    if len(compact(entity)) > MAX_REQUEST_BYTES:
        problems.append("payload too large")
    return [p for p in problems if p is not None]


def compound_keys(value: Any) -> list[str]:
    if isinstance(value, dict):
        return [k for k, v in value.items() for k in (k, *compound_keys(v))]
    if isinstance(value, list):
        return [k for v in value for k in compound_keys(v)]
    return []


@pytest.mark.parametrize(
    "record",
    [
        r
        for r in EXCHANGES
        if r.get("request", {}).get("path") == "/v2/entities"
        and isinstance(r["request"]["body"], dict)
        and not any(h.startswith("Fiware-") for h in r["request"]["headers"])  # 400s for tenant headers
    ],
    ids=lambda r: r["name"],
)
def test_validator_agrees_with_a_real_orion(record: dict[str, Any]) -> None:
    rejected_as_bad_request = record["response"]["status"] == 400
    assert bool(orion_objections(record["request"]["body"])) == rejected_as_bad_request


@pytest.mark.slow
@given(st.lists(attribute_messages(), max_size=5))
def test_encoded_entities_are_accepted_by_orion(items: list[tuple[str, Message]]) -> None:
    entity = encode_entity("robot_1", "ROBOT", dict(items))
    assert orion_objections(entity) == []
    assert all(identifier_error("attribute name", k) is None for k in compound_keys(entity))


def test_strings_with_forbidden_characters_are_escaped_not_refused() -> None:
    error = RanError(
        code="bad_sequence",
        message="sequence_number: must be 1..length=3, got 4 (task 'pick <A>'; x=1)",
        task_id=id_for("pick (A)"),
    )
    attr = encode_attribute("ran_error", error)
    assert not has_forbidden_chars(attr)
    assert attr["value"]["message"]["value"] == (
        "sequence_number: must be 1..length%3D3, got 4 %28task %27pick %3CA%3E%27%3B x%3D1%29"
    )
    assert attr["value"]["task_id"]["value"]["description"]["value"] == "pick %28A%29"


@pytest.mark.parametrize("encode", [encode_entity, encode_entity_json])
@pytest.mark.parametrize(
    ("entity_id", "entity_type", "path", "problem"),
    [
        ("robot(4)", "ROBOT", "id", "Invalid characters in entity id"),
        ("robot 1", "ROBOT", "id", "Invalid characters in entity id"),
        ("robot/1", "ROBOT", "id", "Invalid characters in entity id"),
        ("róbot", "ROBOT", "id", "Invalid characters in entity id"),
        ("", "ROBOT", "id", "entity id length: 0, min length supported: 1"),
        ("r" * 257, "ROBOT", "id", "entity id length: 257, max length supported: 256"),
        ("robot_1", "RO#BOT", "type", "Invalid characters in entity type"),
    ],
)
def test_encode_entity_refuses_identifiers_orion_rejects(
    encode: Any, entity_id: str, entity_type: str, path: str, problem: str
) -> None:
    with pytest.raises(CodecError) as info:
        encode(entity_id, entity_type, {"current_motion": Motion()})
    assert (info.value.path, info.value.problem) == (path, problem)


def test_encode_entity_accepts_the_longest_identifier() -> None:
    assert encode_entity("r" * 256, "ROBOT", {})["id"] == "r" * 256


def test_every_attribute_name_and_type_is_an_orion_identifier() -> None:
    for name, cls in ATTRIBUTES.items():
        assert identifier_error("attribute name", name) is None
        assert identifier_error("attribute type", cls.ROS_TYPE) is None


def test_encode_attribute_refuses_a_mismatched_message() -> None:
    with pytest.raises(CodecError) as info:
        encode_attribute("current_motion", RanError())
    assert str(info.value) == "current_motion: expected a Motion message, got RanError"
    with pytest.raises(CodecError, match="unknown attribute"):
        encode_attribute("battery_level", Motion())


# --- splitting a batch update under the request limit --------------------------------------------------


def fleet(n: int) -> list[dict[str, Any]]:
    return [encode_entity(f"robot_{i}", "ROBOT", {"current_motion": Motion()}) for i in range(n)]


@pytest.mark.slow
@given(st.integers(0, 40), st.integers(1_700, 20_000))
def test_split_batch_keeps_every_entity_in_order_and_under_the_limit(n: int, limit: int) -> None:
    entities = fleet(n)
    bodies = split_batch(entities, limit)
    assert all(len(body) <= limit for body in bodies)
    parsed = [json.loads(body) for body in bodies]
    assert all(p["actionType"] == "append" and p["entities"] for p in parsed)
    assert [e for p in parsed for e in p["entities"]] == entities
    assert all(body == compact(p) for body, p in zip(bodies, parsed))  # compact JSON, nothing else
    # greedy: the first entity of each body would not have fitted into the one before
    for body, nxt in zip(bodies, parsed[1:]):
        assert len(body) + 1 + len(compact(nxt["entities"][0])) > limit


def test_split_batch_for_a_thousand_robots_uses_few_requests() -> None:
    entities = fleet(1000)
    total = sum(len(compact(e)) for e in entities)
    bodies = split_batch(entities)
    assert all(len(b) <= MAX_REQUEST_BYTES for b in bodies)
    assert len(bodies) == -(-total // MAX_REQUEST_BYTES)  # as few as the sizes allow
    assert split_batch([]) == []


def test_split_batch_takes_pre_serialized_entities() -> None:
    entities = fleet(300)
    serialized = [encode_entity_json(e["id"], "ROBOT", {"current_motion": Motion()}) for e in entities]
    assert split_batch(serialized, 100_000) == split_batch(entities, 100_000)
    with pytest.raises(CodecError) as info:
        split_batch(serialized, 1_000)
    assert info.value.path == "entities[0]"


def test_a_body_of_exactly_the_limit_is_allowed() -> None:
    entity = fleet(1)[0]
    exact = len(split_batch([entity])[0])
    assert len(split_batch([entity], exact)) == 1
    with pytest.raises(CodecError) as info:
        split_batch([entity], exact - 1)
    assert info.value.path == "robot_0"
    assert "too large" in info.value.problem


def test_an_entity_over_the_limit_alone_is_refused() -> None:
    big = {"id": "robot_big", "type": "ROBOT", "blob": {"type": "Text", "value": "a" * MAX_REQUEST_BYTES}}
    with pytest.raises(CodecError) as info:
        split_batch([fleet(1)[0], big])
    assert str(info.value).startswith("robot_big: entity encodes to 1048")


def test_split_batch_action_type() -> None:
    (body,) = split_batch(fleet(1), action_type="update")
    assert json.loads(body)["actionType"] == "update"
