"""NGSI v2 subscriptions: parsing and checking the payload, rendering it back, deciding whether an
entity change triggers it and what the notification carries.

Triggering, as Orion 4.7 does it (and the recordings show): a write notifies a subscription when the
entity matches one of ``subject.entities`` (``id``/``idPattern``, ``type``/``typePattern``) inside the
subscription's service path, and one of the written attributes actually changed (value or type; its
metadata when ``notifyOnMetadataChange``, the default) and is in ``condition.attrs`` (any attribute
when that list is empty). ``options=forcedUpdate`` counts every written attribute (only those) as changed. No
notification is sent when a subscription is created, nor when an entity is deleted; deleting an
attribute is a change of it (Orion's functional tests 0000_subs_attrs_deletion).
The payload carries the entity with ``notification.attrs`` in that order (all attributes when empty;
``exceptAttrs`` removes some; ``onlyChangedAttrs`` keeps the changed ones), not only the changed one.

A subscription with ``throttling`` sends nothing within that many seconds of its last notification, as
Orion does. Accepted and shown but not acted upon: ``notification.metadata`` (metadata filter).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any
from urllib.parse import urlsplit

from vcran.broker.dates import iso_time, parse_time
from vcran.broker.model import Change, Entity, render_entity
from vcran.broker.protocol import bad_request, not_implemented, parse_error
from vcran.broker.scope import EntitySelector, parse_subscription_selector, path_covers
from vcran.core.orion_rules import has_forbidden_chars, is_identifier

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
    timeout: int = 0  # http.timeout, milliseconds; 0: the broker's default (Orion's -httpTimeout)
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
    max_fails_limit: int = 0  # notification.maxFailsLimit; 0: none

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
            if 0 < self.max_fails_limit <= self.fails_counter:  # cache/subCache.cpp: maxFailsReached
                self.status = "inactive"
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
        notification["http"] = {"url": self.url, **({"timeout": self.timeout} if self.timeout > 0 else {})}
        if self.metadata:
            notification["metadata"] = list(self.metadata)
        for key, value in (
            ("lastFailure", None if self.last_failure is None else iso_time(self.last_failure)),
            ("lastFailureReason", self.last_failure_reason),
            ("lastSuccess", None if self.last_success is None else iso_time(self.last_success)),
            ("lastSuccessCode", self.last_success_code),
            ("maxFailsLimit", self.max_fails_limit or None),
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
#
# In the order and with the words of Orion's jsonParseV2/parseSubscription.cpp (functional tests
# 1316_create_subscription/post_subs_errors.test and 1947_1972_invalid_subs_crash show most of them).

#: Notification kinds Orion accepts, of which this broker implements ``http``.
NOTIFICATION_KINDS = ("http", "httpCustom", "mqtt", "mqttCustom", "kafka", "kafkaCustom")
#: ``attrsFormat`` values Orion accepts (common/RenderFormat.cpp stringToRenderFormat) but this broker
#: cannot render: answered 501.
UNSUPPORTED_FORMATS = ("uniqueValues", "custom", "simplifiedNormalized", "simplifiedKeyValues")
#: Orion's largest ``http.timeout``, in milliseconds (common/limits.h MAX_HTTP_TIMEOUT).
MAX_HTTP_TIMEOUT = 1_800_000


def _typed(obj: dict[str, Any], key: str, kind: type, what: str, description: str = "") -> Any:
    """Orion's ``getStringOpt``/``getBoolOpt``/``getInt64Opt`` (jsonParseV2/utilsParse.cpp): None when
    absent, else the value, which must have the JSON type (``null`` has none of them)."""
    if key not in obj:
        return None
    value = obj[key]
    if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
        raise bad_request(f"{description or key} is not {what}")
    return value


def _string_vector(raw: Any, name: str) -> tuple[str, ...]:
    """Orion's parseStringVector (jsonParseV2/parseStringVector.cpp) for attribute name lists."""
    if not isinstance(raw, list):
        raise bad_request(f"the field /{name}/ must be a JSON array")
    for i, item in enumerate(raw):
        if not isinstance(item, str):
            raise bad_request(f"only JSON Strings allowed in string vector /{name}/")
        if item in raw[i + 1 :]:
            raise bad_request(f"duplicated item /{item}/ in array")
        if item and not is_identifier(item):
            raise bad_request("forbidden characters in attribute name")
        if not item:
            raise bad_request(f"empty string found in string vector /{name}/")
    return tuple(raw)


def _subject(raw: Any) -> dict[str, Any]:
    if not isinstance(raw, dict):
        raise bad_request("subject is not an object")
    if "entities" not in raw:
        raise bad_request("no subject entities specified")
    entities = raw["entities"]
    if not isinstance(entities, list):
        raise bad_request("/entities/ is not an array")
    selectors = tuple(dict.fromkeys(parse_subscription_selector(e) for e in entities))  # Orion drops repeats
    if not selectors:
        raise bad_request("subject entities is empty")
    fields: dict[str, Any] = {"entities": selectors}
    if "condition" in raw:
        condition = raw["condition"]
        if not isinstance(condition, dict):
            raise bad_request("condition is not an object")
        if not condition:
            raise bad_request("condition is empty")
        if "attrs" in condition:
            fields["condition_attrs"] = _string_vector(condition["attrs"], "attrs")
        for key in ("jexlExpression", "expression"):
            if key in condition:
                raise not_implemented(f"subscription condition {key} (q, mq, geo, JEXL)")
        if "alterationTypes" in condition:
            raise not_implemented("subscription condition alterationTypes")
        flag = _typed(condition, "notifyOnMetadataChange", bool, "a bool")
        if flag is not None:
            fields["notify_on_metadata_change"] = flag
    return fields


def _http(http: Any) -> dict[str, Any]:
    if not isinstance(http, dict):
        raise bad_request("http notification is not an object")
    if "url" not in http:
        raise bad_request("url http notification is missing")
    url = _typed(http, "url", str, "a string", "url http notification")
    if has_forbidden_chars(url):
        raise bad_request("forbidden characters in http field /url/")
    timeout = _typed(http, "timeout", int, "an int")
    if timeout is not None and not 0 <= timeout <= MAX_HTTP_TIMEOUT:
        raise bad_request(f"timeout field must be an integer between 0 and {MAX_HTTP_TIMEOUT}")
    parts = urlsplit(url)
    if parts.scheme == "mqtt":
        raise bad_request("mqtt URL cannot be used in http notifications")
    if parts.scheme == "kafka":
        raise bad_request("kafka URL cannot be used in http notifications")
    if parts.scheme not in ("http", "https") or not parts.hostname:
        raise bad_request("Invalid URL parsing notification url")
    return {"url": url, "timeout": timeout or 0}


def _notification(raw: Any) -> dict[str, Any]:
    if not isinstance(raw, dict):
        raise bad_request("notification is not an object")
    kinds = [kind for kind in NOTIFICATION_KINDS if kind in raw]
    if len(kinds) > 1:
        raise bad_request("only one of http, httpCustom, mqtt, mqttCustom, kafka or kafkaCustom is allowed")
    if not kinds:
        raise bad_request("http, httpCustom, mqtt, mqttCustom, kafka or kafkaCustom is missing")
    if kinds[0] != "http":
        raise not_implemented("notification.httpCustom, MQTT and Kafka notifications")
    fields = _http(raw["http"])
    if "attrs" in raw and "exceptAttrs" in raw:
        raise bad_request("http notification has attrs and exceptAttrs")
    if "attrs" in raw:
        fields["attrs"] = _string_vector(raw["attrs"], "attrs")
        fields["except_attrs"] = ()
    elif "exceptAttrs" in raw:
        fields["except_attrs"] = _string_vector(raw["exceptAttrs"], "exceptAttrs")
        if not fields["except_attrs"]:
            raise bad_request("http notification has exceptAttrs is empty")
        fields["attrs"] = ()
    only_changed = _typed(raw, "onlyChangedAttrs", bool, "a bool")
    if only_changed is not None:
        fields["only_changed_attrs"] = only_changed
    covered = _typed(raw, "covered", bool, "a bool")
    if covered:
        if not fields.get("attrs"):
            raise bad_request("covered true cannot be used if notification attributes list is empty")
        raise not_implemented("notification.covered")
    if "metadata" in raw:
        fields["metadata"] = _string_vector(raw["metadata"], "metadata")
    attrs_format = _typed(raw, "attrsFormat", str, "a string")
    if attrs_format is None:
        attrs_format = "normalized"  # Orion resets it whenever a notification is given, on update too
    elif attrs_format in UNSUPPORTED_FORMATS:
        raise not_implemented(f"attrsFormat {attrs_format}")
    elif attrs_format not in ATTRS_FORMATS:
        raise bad_request("invalid attrsFormat, accepted values: normalized, simplifiedNormalized, keyValues, "
                          "simplifiedkeyValues, values")
    fields["attrs_format"] = attrs_format
    max_fails = _typed(raw, "maxFailsLimit", int, "an int")
    if max_fails is not None:
        if max_fails <= 0:
            raise bad_request("maxFailsLimit must be greater than zero")
        fields["max_fails_limit"] = max_fails
    return fields


def parse_subscription(payload: Any, *, update: bool = False) -> dict[str, Any]:
    """The fields a create (all required ones) or update (any subset) request sets, as keyword
    arguments of :class:`Subscription`; raises the error Orion gives for a malformed payload."""
    if not isinstance(payload, dict):
        raise parse_error()
    if not payload:
        raise bad_request("empty payload")
    fields: dict[str, Any] = {}
    description = _typed(payload, "description", str, "a string")
    if description is not None:
        if len(description.encode()) > MAX_DESCRIPTION:
            raise bad_request("max description length exceeded")
        if has_forbidden_chars(description):
            raise bad_request("forbidden characters in description")
        fields["description"] = description
    for key, parse, what in (("subject", _subject, "subject"), ("notification", _notification, "notification")):
        if key in payload:
            fields.update(parse(payload[key]))
        elif not update:
            raise bad_request(f"no {what} for subscription specified")
    expires = _typed(payload, "expires", str, "a string")
    if expires is not None:
        if expires == "":
            fields["expires"] = None
        else:
            moment = parse_time(expires)  # common/globals.cpp parse8601Time; Orion keeps whole seconds
            if moment is None:
                raise bad_request("expires has an invalid format")
            fields["expires"] = int(moment)
    status = _typed(payload, "status", str, "a string")
    if status is not None:
        if status not in STATUSES:
            raise bad_request("status is not valid: it has to be either active, inactive or oneshot")
        fields["status"] = status
    throttling = _typed(payload, "throttling", int, "an int")
    if throttling is not None:
        fields["throttling"] = throttling  # Orion takes any int; zero or less means none
    return fields
