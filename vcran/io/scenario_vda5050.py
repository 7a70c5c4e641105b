"""A VDA 5050 scenario's ``[[script]]`` (docs/contract.md §11): the master's ``order`` and ``instantActions`` messages
at given times, the scripted run's analogue of the original VC-RAN's JMeter list (docs/scenarios.md, "VDA 5050
vehicles").

An entry of kind ``order`` or ``instantActions`` gives the message as VDA 5050 writes it, without its
header: ``message`` as a TOML table or a JSON text, keys spelled as the specification spells them
(``orderId``, ``nodes``, ``nodePosition`` ...). vcran stamps the header as a master would (§6.4:
``headerId`` counting from 0 per robot and topic, in the order the messages are sent; the timestamp of
the entry's time on the vehicles' calendar; the vehicle's version, manufacturer and serial number) and
checks the message against the vehicle's version's official schema as it loads, naming the offending
field. ``payload`` instead sends a text as it is, unchecked: a master's malformed message, which the
vehicle refuses with a ``validationError``.

Stamping needs every entry's time and vehicle, so an entry is read into a :class:`Draft` first and
stamped once all are read (:func:`stamped`). The message is checked here, as it is built (the shared model
imports no protocol); what relates an entry to the scenario (its robot, its protocol, a message or a
payload) is :mod:`vcran.core.validity.protocol`'s.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from datetime import datetime
from typing import Any

import orjson

from vcran.core.scenario import VDA5050, RobotConfig, ScriptEntry, Settings
from vcran.core.vda5050.enums import Topic, Version
from vcran.core.vda5050.header import DEFAULT_EPOCH, epoch_of, timestamp
from vcran.io.toml_table import Table

__all__ = ["HEADER", "Draft", "draft", "header", "stamped"]

#: The header's fields (§6.4), which vcran stamps.
HEADER = ("headerId", "timestamp", "version", "manufacturer", "serialNumber")


@dataclass(frozen=True, slots=True)
class Draft:
    """A script message read but not yet stamped: ``body`` is the message without its header (None:
    ``raw`` is a payload sent as it is)."""

    t: float
    robot: str
    topic: str
    body: dict[str, Any] | None
    raw: str | None
    table: Table


def draft(t: Table, time: float, robot: str, topic: str) -> Draft:
    """The ``order`` or ``instantActions`` entry ``t`` (its ``t`` and ``robot`` read already)."""
    message, payload = t.document("message", None), t.document("payload", None)
    if (message is None) == (payload is None):
        t.fail("message", "give either message (checked, stamped by vcran) or payload (a text sent as it is)")
    if payload is not None:
        if isinstance(payload, dict):
            payload = _json_text(t, "payload", payload)
        return Draft(time, robot, topic, None, payload, t)
    if isinstance(message, str):
        try:
            message = json.loads(message)
        except (ValueError, RecursionError) as exc:  # JSONDecodeError, or an integer of over 4300 digits
            t.fail("message", f"not valid JSON: {str(exc).split('; use sys.set_int_max_str_digits', 1)[0]}")
    if not isinstance(message, dict):
        t.fail("message", f"expected the {topic} message as a table or a JSON object, got {type(message).__name__}")
    _json_text(t, "message", message)
    stamp = next((key for key in HEADER if key in message), None)
    if stamp is not None:
        t.fail("message", f"{stamp} is the header's, which vcran stamps (§6.4: headerId per robot and topic in "
                          "the order sent); leave it out, or send the message as it is with payload")
    return Draft(time, robot, topic, message, None, t)


def _json_text(t: Table, key: str, value: dict[str, Any]) -> str:
    try:  # TOML dates and times have no JSON form; nor has NaN in a message
        return json.dumps(value, ensure_ascii=False, allow_nan=False)
    except (TypeError, ValueError, RecursionError) as exc:
        t.fail(key, f"not a JSON value: {exc}")


def header(robot: RobotConfig, n: int, t: float, epoch: datetime = DEFAULT_EPOCH) -> dict[str, Any]:
    """The header vcran stamps on ``robot``'s ``n``-th script message of a topic (from 0), sent at ``t``
    (on the scenario's calendar, ``epoch``)."""
    _, manufacturer, serial, version = robot.vda5050_identity
    return {"headerId": n, "timestamp": timestamp(t, epoch), "version": version, "manufacturer": manufacturer,
            "serialNumber": serial}


def _wire(doc: dict[str, Any]) -> bytes | None:
    """The stamped message as the master sends it, which its trace record is (docs/outputs.md): the text of the
    document it was decoded from, keys as the script wrote them. None where orjson cannot write it (an integer
    beyond 64 bits, a lone surrogate): the trace then encodes the decoded message."""
    try:
        return orjson.dumps(doc)
    except orjson.JSONEncodeError:
        return None


def stamped(drafts: Sequence[Draft], robots: Mapping[str, RobotConfig], settings: Settings) -> list[ScriptEntry]:
    """The drafts as script entries, in the same order: each message with its header, checked against its
    vehicle's version's schema. Headers count in time order (equal times in the drafts' order, the file's),
    timestamps on the scenario's calendar (its ``epoch``, read and checked already). Outside a VDA 5050
    scenario, or for a robot that is not one of its vehicles, the body is kept as it is (``raw``) for the
    scenario's rules to refuse with the reason."""
    from vcran.core.vda5050 import codec  # here: the schemas' validators cost an OPIL scenario's load 0.1 s

    protocol = settings.protocol
    epoch = epoch_of(settings.epoch) if protocol == VDA5050 else DEFAULT_EPOCH
    order = sorted(range(len(drafts)), key=lambda i: drafts[i].t)
    counts: dict[tuple[str, str], int] = {}
    out: list[ScriptEntry | None] = [None] * len(drafts)
    for i in order:
        d = drafts[i]
        robot = robots.get(d.robot)
        if d.body is None or protocol != VDA5050 or robot is None or robot.manufacturer is None \
                or robot.serial_number is None:
            out[i] = ScriptEntry(d.t, d.robot, d.topic, raw=d.raw if d.body is None else d.body)
            continue
        n = counts.get((d.robot, d.topic), 0)
        counts[(d.robot, d.topic)] = n + 1
        version = robot.vda5050_identity[3]
        doc = {**header(robot, n, d.t, epoch), **d.body}
        message = codec.decode(Topic(d.topic), doc, Version(version))
        if isinstance(message, codec.Invalid):
            d.table.fail("message", f"{message.path}: {message.problem} (VDA 5050 {version}'s schema)")
        out[i] = ScriptEntry(d.t, d.robot, d.topic, message, wire=_wire(doc))
    return out  # type: ignore[return-value]  # every index was filled
