"""The broker's state (tenants of entities and subscriptions) and the per-request view that handlers use.

Handlers (:mod:`vcran.broker.entities`, :mod:`vcran.broker.batch`, the subscription resources in
:mod:`vcran.broker.engine`) receive a :class:`Context`: the checked request (scope, URI parameters,
options, parsed body) plus the operations every handler needs — find an entity with read or write
semantics, and turn an entity change into notifications.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

from vcran.broker.model import BUILTIN_ATTRIBUTES, Change, Entity
from vcran.broker.protocol import (
    ENTITY_NOT_FOUND,
    NgsiError,
    Notification,
    Request,
    bad_request,
    not_found,
    render_json,
)
from vcran.broker.scope import Scope
from vcran.broker.subscriptions import Subscription

#: What Orion 4.7 sends as User-Agent on notifications; kept so that listeners that check it agree.
NOTIFICATION_USER_AGENT = "orion/4.7.0-next libcurl/7.88.1"
NOTIFICATION_CONTENT_TYPE = "application/json; charset=utf-8"
DEFAULT_LIMIT = 20
MAX_LIMIT = 1000


@dataclass(slots=True)
class Tenant:
    """One ``Fiware-Service``: entities in creation order (Orion's default order), subscriptions."""

    entities: dict[tuple[str, str, str], Entity] = field(default_factory=dict)  # (path, id, type)
    subscriptions: dict[str, Subscription] = field(default_factory=dict)

    def add(self, entity: Entity) -> None:
        self.entities[(entity.service_path, entity.id, entity.type)] = entity

    def remove(self, entity: Entity) -> None:
        del self.entities[(entity.service_path, entity.id, entity.type)]


@dataclass(slots=True)
class Context:
    request: Request
    scope: Scope
    params: Mapping[str, str]
    options: frozenset[str]
    body: Any
    correlator: str
    tenants: dict[str, Tenant]
    clock: Callable[[], float]
    text: str | None = None  # a text/plain body (only PUT .../value takes one)
    #: Every value of the parameters whose repeats add up (engine.ADDING_PARAMS); ``params`` holds the last.
    repeated: Mapping[str, list[str]] = field(default_factory=dict)
    notifications: list[Notification] = field(default_factory=list)

    # --- request parameters ---

    def tenant(self, *, create: bool = False) -> Tenant:
        """The request's tenant; reads of a tenant never written see an empty one."""
        if create:
            return self.tenants.setdefault(self.scope.tenant, Tenant())
        return self.tenants.get(self.scope.tenant) or Tenant()

    def attrs_param(self) -> list[str] | None:
        """``attrs``, plus the builtins that ``options=dateCreated,dateModified`` (deprecated spellings
        of ``attrs=*,dateCreated``) ask for."""
        attrs = self.params.get("attrs")
        names = attrs.split(",") if attrs is not None else None
        for builtin in BUILTIN_ATTRIBUTES:
            if builtin in self.options:
                names = names or ["*"]
                if builtin not in names:
                    names.append(builtin)
        return names

    def render_format(self) -> str:
        """Orion's precedence: keyValues, then values, then unique; normalized by default."""
        for fmt in ("keyValues", "values", "unique"):
            if fmt in self.options:
                return fmt
        return "normalized"

    def page_bounds(self) -> tuple[int, int]:
        """``limit`` (default 20, at most 1000) and ``offset`` (default 0), checked as Orion's
        ``uriArgumentGet`` (rest/rest.cpp) does. ``limit=0`` is valid and selects nothing, which with
        ``options=count`` just counts (mongoBackend/MongoGlobal.cpp: "limit != 0 will cause skipping";
        functional test 1041_GET_v2_entities_options_count/get_entities_option_count_multitenant.test)."""
        limit_text, offset_text = self.params.get("limit"), self.params.get("offset")
        if limit_text is not None and not limit_text.isdigit():
            raise bad_request(f"Bad pagination limit: /{limit_text}/ [must be a positive integer number]")
        if offset_text is not None and not offset_text.isdigit():
            raise bad_request(f"Bad pagination offset: /{offset_text}/ [must be a decimal number]")
        limit = DEFAULT_LIMIT if limit_text is None else int(limit_text)
        if limit > MAX_LIMIT:
            raise bad_request(f"Bad pagination limit: /{limit_text}/ [max: {MAX_LIMIT}]")
        return limit, 0 if offset_text is None else int(offset_text)

    # --- finding entities ---

    def _named(self, entity_id: str, entity_type: str | None) -> Iterator[Entity]:
        for entity in self.tenant().entities.values():
            if entity.id == entity_id and (entity_type is None or entity.type == entity_type):
                yield entity

    def find(self, entity_id: str, entity_type: str | None) -> Entity:
        """Read semantics: the one entity with this id (and type) among the paths the request sees."""
        found = _single([e for e in self._named(entity_id, entity_type) if self.scope.sees(e.service_path)])
        if found is None:
            raise not_found(ENTITY_NOT_FOUND)
        return found

    def writable(self, entity_id: str, entity_type: str | None) -> Entity | None:
        """Write semantics: the entity in the write's one path (``/`` when the header is absent)."""
        path = self.scope.write_path()
        return _single([e for e in self._named(entity_id, entity_type) if e.service_path == path])

    def find_for_write(self, entity_id: str, entity_type: str | None) -> Entity:
        found = self.writable(entity_id, entity_type)
        if found is None:
            raise not_found(ENTITY_NOT_FOUND)
        return found

    # --- notifications ---

    def changed(self, entity: Entity, changes: Mapping[str, Change]) -> None:
        """A write to ``entity`` is done: stamp ``dateModified`` if it changed anything, and queue one
        notification per subscription it triggers, in subscription creation order, numbered
        ``cbnotif=1, 2, ...`` within the request.

        ``options=forcedUpdate`` makes every written attribute a change, as Orion's ``mergeAttrInfo``
        does (mongoBackend/MongoCommonUpdate.cpp: ``valueChanged = forcedUpdate || ...``): it triggers
        the subscriptions on those attributes and moves ``dateModified`` (the attribute was modified, so
        the entity was), on every update endpoint and ``op/update`` alike."""
        forced = "forcedUpdate" in self.options
        now = self.clock()
        if changes and (forced or any(change.value or change.metadata for change in changes.values())):
            entity.modified = now
        for subscription in self.tenant().subscriptions.values():
            if not subscription.triggered_by(entity, changes, forced=forced, now=now):
                continue
            changed = subscription.changed_names(changes, forced=forced)
            headers: list[tuple[str, str]] = []
            if self.scope.tenant:
                headers.append(("Fiware-Service", self.scope.tenant))
            headers += [
                ("Fiware-Servicepath", entity.service_path),
                ("Accept", "application/json"),
                ("Content-Type", NOTIFICATION_CONTENT_TYPE),
                ("Fiware-Correlator", f"{self.correlator}; cbnotif={len(self.notifications) + 1}"),
                ("Ngsiv2-AttrsFormat", subscription.attrs_format),
                ("User-Agent", NOTIFICATION_USER_AGENT),
            ]
            body = render_json(subscription.payload(entity, changed))
            subscription.sent(now)
            self.notifications.append(
                Notification(subscription.id, self.scope.tenant, subscription.url, tuple(headers), body,
                             subscription.timeout / 1000 if subscription.timeout else None)
            )


def _single(matches: list[Entity]) -> Entity | None:
    """The one match, None for none; several (same id, other types, no type given) is Orion's 409."""
    if len(matches) > 1:
        raise NgsiError(409, "TooManyResults", "More than one matching entity. Please refine your query")
    return matches[0] if matches else None
