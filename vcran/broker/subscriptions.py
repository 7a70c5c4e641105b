"""NGSI v2 subscriptions: parsing and checking the payload, rendering it back, deciding whether an
entity change triggers it and what the notification carries.

Triggering, as Orion 4.7 does it (and the recordings show): a write notifies a subscription when the
entity matches one of ``subject.entities`` (``id``/``idPattern``, ``type``/``typePattern``) inside the
subscription's service path, and one of the written attributes actually changed (value or type; its
metadata when ``notifyOnMetadataChange``, the default) and is in ``condition.attrs`` (any attribute
when that list is empty). ``options=forcedUpdate`` counts every written attribute as changed. No
notification is sent when a subscription is created, nor when an entity or attribute is deleted.
The payload carries the entity with ``notification.attrs`` in that order (all attributes when empty;
``exceptAttrs`` removes some; ``onlyChangedAttrs`` keeps the changed ones), not only the changed one.

A subscription with ``throttling`` sends nothing within that many seconds of its last notification, as
Orion does. Accepted and shown but not acted upon: ``notification.metadata`` (metadata filter).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any
from urllib.parse import urlsplit

from vcran.broker.model import Change, Entity, iso_time, render_entity
from vcran.broker.protocol import bad_request, not_implemented
from vcran.broker.scope import EntitySelector, parse_selector, path_covers
from vcran.core.orion_rules import has_forbidden_chars

ATTRS_FORMATS = ("normalized", "keyValues", "values")
STATUSES = ("active", "inactive", "oneshot")
MAX_DESCRIPTION = 1024


@dataclass(slots=True)
class Subscription:
    """A subscription and its delivery record (``timesSent``, ``lastSuccess``...), owned by one tenant."""

    id: str
    service_path: str
    entities: tuple[EntitySelector, ...]
    url: str
    description: str | None = None
    condition_attrs: tuple[str, ...] = ()
    notify_on_metadata_change: bool = True
    attrs: tuple[str, ...] = ()
    except_attrs: tuple[str, ...] = ()
    attrs_format: str = "normalized"
    only_changed_attrs: bool = False
    metadata: tuple[str, ...] | None = None
    status: str = "active"
    expires: int | None = None  # whole seconds since the epoch, as Orion keeps it
    throttling: int = 0
    times_sent: int = 0
    # The delivery record, in whole seconds as Orion keeps it (cache/subCache.h: int64_t), so that it
    # renders as ``....000Z``.
    last_notification: int | None = None
    last_success: int | None = None
    last_success_code: int | None = None
    last_failure: int | None = None
    last_failure_reason: str | None = None
    fails_counter: int = 0  # consecutive failed deliveries; a success resets it (Orion's failsCounter)

    # --- triggering ---

    def expired(self, now: float) -> bool:
        return self.expires is not None and self.expires < int(now)  # mongoGetSubscriptions.cpp setStatus

    def triggered_by(self, entity: Entity, changes: Mapping[str, Change], *, forced: bool, now: float) -> bool:
        if self.status not in ("active", "oneshot") or self.expired(now):
            return False
        if not path_covers(self.service_path, entity.service_path):
            return False
        if not any(selector.matches(entity) for selector in self.entities):
            return False
        changed = self.changed_names(changes, forced=forced)
        if not (any(name in changed for name in self.condition_attrs) if self.condition_attrs else changed):
            return False
        return not self.throttled(now)

    def throttled(self, now: float) -> bool:
        """Orion's throttling (mongoBackend/MongoCommonUpdate.cpp, "Check 1"): a notification within
        ``throttling`` seconds of the last one is not sent, counted in whole seconds."""
        if self.throttling <= 0 or self.last_notification is None:
            return False
        return self.throttling > int(now) - self.last_notification

    def changed_names(self, changes: Mapping[str, Change], *, forced: bool) -> set[str]:
        return {
            name
            for name, change in changes.items()
            if forced or change.value or (change.metadata and self.notify_on_metadata_change)
        }

    def payload(self, entity: Entity, changed: set[str]) -> dict[str, Any]:
        """The notification body for one entity: ``{"subscriptionId", "data": [entity]}``."""
        if self.except_attrs:
            names: list[str] | None = [n for n in entity.attrs if n not in self.except_attrs]
        else:
            names = list(self.attrs) or None
        if self.only_changed_attrs:
            names = [n for n in (names if names is not None else entity.attrs) if n in changed]
        return {"subscriptionId": self.id, "data": [render_entity(entity, names, self.attrs_format)]}

    # --- delivery record ---

    def sent(self, when: float) -> None:
        self.times_sent += 1
        self.last_notification = int(when)
        if self.status == "oneshot":
            self.status = "inactive"

    def delivered(self, when: float, status_code: int | None, reason: str) -> None:
        """Record a delivery's outcome: any HTTP answer is a success (Orion keeps its code), no answer
        is a failure, counted in ``failsCounter`` until the next success. The status stays ``active``:
        Orion 3.4 dropped ``failed`` (orion-api.md, "Ambiguous subscription status failed not used")."""
        if status_code is None:
            self.last_failure, self.last_failure_reason = int(when), reason
            self.fails_counter += 1
        else:
            self.last_success, self.last_success_code, self.fails_counter = int(when), status_code, 0

    # --- representation ---

    def render(self, now: float) -> dict[str, Any]:
        """As Orion's ``Subscription::toJson`` (apiTypesV2/Subscription.cpp): an empty description, a
        zero throttling and an empty metadata list are left out; times are whole seconds."""
        out: dict[str, Any] = {"id": self.id}
        if self.description:
            out["description"] = self.description
        if self.expires is not None:
            out["expires"] = iso_time(self.expires)
        out["status"] = "expired" if self.expired(now) else self.status
        condition = {"attrs": list(self.condition_attrs), "notifyOnMetadataChange": self.notify_on_metadata_change}
        out["subject"] = {"entities": [s.render() for s in self.entities], "condition": condition}
        notification: dict[str, Any] = {}
        if self.times_sent:
            notification["timesSent"] = self.times_sent
        if self.last_notification is not None:
            notification["lastNotification"] = iso_time(self.last_notification)
        if self.except_attrs:
            notification["exceptAttrs"] = list(self.except_attrs)
        else:
            notification["attrs"] = list(self.attrs)
        notification["onlyChangedAttrs"] = self.only_changed_attrs
        notification["attrsFormat"] = self.attrs_format
        notification["http"] = {"url": self.url}
        if self.metadata:
            notification["metadata"] = list(self.metadata)
        for key, value in (
            ("lastFailure", None if self.last_failure is None else iso_time(self.last_failure)),
            ("lastFailureReason", self.last_failure_reason),
            ("lastSuccess", None if self.last_success is None else iso_time(self.last_success)),
            ("lastSuccessCode", self.last_success_code),
            ("failsCounter", self.fails_counter or None),
        ):
            if value is not None:
                notification[key] = value
        notification["covered"] = False
        out["notification"] = notification
        if self.throttling > 0:
            out["throttling"] = self.throttling
        return out


# --- parsing ---------------------------------------------------------------------------------------------


def _parse_time(text: str) -> int:
    """An ISO 8601 time as Orion reads ``expires`` (common/globals.cpp parse8601Time): no zone means
    UTC, and the fraction of a second is dropped (Orion keeps whole seconds)."""
    moment = datetime.fromisoformat(text)
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=UTC)
    return int(moment.timestamp() // 1)


def _string(obj: dict[str, Any], key: str) -> str | None:
    value = obj.get(key)
    if value is not None and not isinstance(value, str):
        raise bad_request(f"{key} is not a string")
    return value


def _string_list(raw: Any, what: str) -> tuple[str, ...]:
    if not isinstance(raw, list):
        raise bad_request(f"{what} is not an array")
    for item in raw:
        if not isinstance(item, str):
            raise bad_request(f"{what} element is not a string")
        if has_forbidden_chars(item):
            raise bad_request(f"forbidden characters in {what}")
    return tuple(raw)


def _subject(raw: Any) -> dict[str, Any]:
    if not isinstance(raw, dict):
        raise bad_request("subject is not an object")
    if "entities" not in raw:
        raise bad_request("no subject entities specified")
    entities = raw["entities"]
    if not isinstance(entities, list) or not entities:
        raise bad_request("subject entities must be a non-empty array")
    fields: dict[str, Any] = {"entities": tuple(parse_selector(e) for e in entities)}
    if "condition" in raw:
        condition = raw["condition"]
        if not isinstance(condition, dict):
            raise bad_request("condition is not an object")
        if not condition:
            raise bad_request("condition is empty")
        if "expression" in condition:
            raise not_implemented("subscription condition expressions (q, mq, geo)")
        if "alterationTypes" in condition:
            raise not_implemented("subscription condition alterationTypes")
        if "attrs" in condition:
            fields["condition_attrs"] = _string_list(condition["attrs"], "attrs")
        if "notifyOnMetadataChange" in condition:
            flag = condition["notifyOnMetadataChange"]
            if not isinstance(flag, bool):
                raise bad_request("notifyOnMetadataChange is not a bool")
            fields["notify_on_metadata_change"] = flag
    return fields


def _notification(raw: Any) -> dict[str, Any]:
    if not isinstance(raw, dict):
        raise bad_request("notification is not an object")
    if "http" in raw and "httpCustom" in raw:
        raise bad_request("notification has http and httpCustom")
    if "httpCustom" in raw or "mqtt" in raw or "mqttCustom" in raw:
        raise not_implemented("notification.httpCustom and MQTT notifications")
    if "http" not in raw:
        raise bad_request("http notification is missing")
    http = raw["http"]
    if not isinstance(http, dict):
        raise bad_request("http notification is not an object")
    url = http.get("url")
    if not isinstance(url, str):
        raise bad_request("url http notification is missing or not a string")
    if has_forbidden_chars(url):
        raise bad_request("forbidden characters in http field /url/")
    parts = urlsplit(url)
    if parts.scheme not in ("http", "https") or not parts.hostname:
        raise bad_request("Invalid URL parsing notification url")
    fields: dict[str, Any] = {"url": url}
    if "attrs" in raw and "exceptAttrs" in raw:
        raise bad_request("http notification has attrs and exceptAttrs")
    if "attrs" in raw:
        fields["attrs"] = _string_list(raw["attrs"], "attrs")
        fields["except_attrs"] = ()
    elif "exceptAttrs" in raw:
        fields["except_attrs"] = _string_list(raw["exceptAttrs"], "exceptAttrs")
        if not fields["except_attrs"]:
            raise bad_request("http notification has exceptAttrs is empty")
        fields["attrs"] = ()
    if "onlyChangedAttrs" in raw:
        if not isinstance(raw["onlyChangedAttrs"], bool):
            raise bad_request("onlyChangedAttrs is not a bool")
        fields["only_changed_attrs"] = raw["onlyChangedAttrs"]
    if "metadata" in raw:
        fields["metadata"] = _string_list(raw["metadata"], "metadata")
    if "attrsFormat" in raw:
        if raw["attrsFormat"] not in ATTRS_FORMATS:
            raise bad_request("invalid attrsFormat, accepted values: legacy, normalized, keyValues, values")
        fields["attrs_format"] = raw["attrsFormat"]
    return fields


def parse_subscription(payload: Any, *, update: bool = False) -> dict[str, Any]:
    """The fields a create (all required ones) or update (any subset) request sets, as keyword
    arguments of :class:`Subscription`; raises the error Orion gives for a malformed payload."""
    if not isinstance(payload, dict):
        raise bad_request("not a JSON object")
    if not payload:
        raise bad_request("empty payload")
    fields: dict[str, Any] = {}
    description = _string(payload, "description")
    if description is not None:
        if len(description) > MAX_DESCRIPTION:
            raise bad_request("max description length exceeded")
        if has_forbidden_chars(description):
            raise bad_request("forbidden characters in description")
        fields["description"] = description
    for key, parse, what in (("subject", _subject, "subject"), ("notification", _notification, "notification")):
        if key in payload:
            fields.update(parse(payload[key]))
        elif not update:
            raise bad_request(f"no {what} for subscription specified")
    expires = _string(payload, "expires")
    if expires is not None:
        if expires == "":
            fields["expires"] = None
        else:
            try:
                fields["expires"] = _parse_time(expires)
            except ValueError:
                raise bad_request("expires has an invalid format") from None
    status = _string(payload, "status")
    if status is not None:
        if status not in STATUSES:
            raise bad_request("status is not valid: it has to be either active or inactive")
        fields["status"] = status
    if "throttling" in payload:
        throttling = payload["throttling"]
        if isinstance(throttling, bool) or not isinstance(throttling, int) or throttling < 0:
            raise bad_request("throttling must be a non-negative integer")
        fields["throttling"] = throttling
    return fields
