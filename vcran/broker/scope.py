"""Tenants (``Fiware-Service``) and service paths (``Fiware-ServicePath``): which entities a request sees.

Orion's rules (manual: multitenancy, service_path; confirmed by the recordings):

- a tenant is an isolated database; its name is case-insensitive (``Plant_A`` is ``plant_a``); no
  header means the default tenant;
- an entity belongs to exactly one service path, ``/`` when created without the header;
- a query without the header sees every path (``/#``); ``/a`` sees only ``/a``, not ``/a/b`` nor ``/``;
  ``/a/#`` sees ``/a`` and everything below it; a comma-separated list sees the union;
- a write names one plain path, ``/`` without the header, and finds existing entities only there (Orion's
  postUpdateContext.cpp; PATCH and DELETE refuse ``#`` and lists with their own words, rest.cpp);
- a subscription's path selects the entities it watches, ``/#`` when created without the header.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

from vcran.broker.model import Entity
from vcran.broker.protocol import Request, bad_request
from vcran.core.orion_rules import (
    IDENTIFIER_MAX,
    SERVICE_PATH_MAX_PATHS,
    is_identifier,
    service_path_error,
    split_service_paths,
    tenant_error,
    update_service_path_error,
)

ROOT_PATH = "/"
EVERYTHING = "/#"


def path_covers(pattern: str, path: str) -> bool:
    """True when service path ``pattern`` (possibly recursive, ``/a/#``) covers entity path ``path``."""
    if pattern == EVERYTHING:
        return True
    if pattern.endswith("/#"):
        base = pattern[:-2]
        return path == base or path.startswith(base + "/")
    return path == pattern


@dataclass(frozen=True, slots=True)
class Scope:
    """The tenant and service paths of one request, validated."""

    tenant: str  # lower-cased; "" is the default tenant
    paths: tuple[str, ...]  # as given; () when the request had no Fiware-ServicePath

    @classmethod
    def of(cls, request: Request) -> Scope:
        """Read the headers; a malformed service path is an error here, a malformed tenant later
        (:meth:`check_tenant`), in the order Orion reports them (rest/rest.cpp servicePathCheck, whose
        PATCH and DELETE refuse several paths and a recursive ``#``, whatever the resource)."""
        header = request.header("Fiware-ServicePath")
        paths: tuple[str, ...] = ()
        if header is not None and header.strip():
            paths = tuple(split_service_paths(header))
            if len(paths) > SERVICE_PATH_MAX_PATHS:
                raise bad_request("too many service paths - a maximum of ten service paths is allowed")
            verb = {"PATCH": "in patch update request", "DELETE": "in DELETE operation"}.get(request.method)
            for path in paths:
                error = service_path_error(path)
                if error is not None and (not path.startswith("/") or path.startswith("//")):
                    raise bad_request(error)
                if verb is not None and len(paths) > 1:
                    raise bad_request("more than one servicepath in patch update request is not allowed"
                                      if request.method == "PATCH"
                                      else "more than one servicepath is not allowed in DELETE operation")
                if error is not None:
                    raise bad_request(error)
                if verb is not None and (path == EVERYTHING or path.endswith("/#")):
                    raise bad_request(f"servicepath with wildcard # is not allowed {verb}")
        return cls((request.header("Fiware-Service") or "").lower(), paths)

    def check_tenant(self) -> None:
        error = tenant_error(self.tenant)
        if error is not None:
            raise bad_request(error)

    def sees(self, entity_path: str) -> bool:
        """Query semantics: does this request see an entity in ``entity_path``?"""
        return any(path_covers(p, entity_path) for p in self.paths or (EVERYTHING,))

    def write_path(self) -> str:
        """The one path a write names, ``/`` without the header: Orion's postUpdateContext.cpp, through
        which every entity write goes, sets the root path then, so a write without the header finds
        only entities in ``/`` (functional test 3640_PATCH_update_with_wrong_servicepath, step 09)."""
        if not self.paths:
            return ROOT_PATH
        if len(self.paths) > 1:
            raise bad_request("more than one service path in context update request")
        error = update_service_path_error(self.paths[0])
        if error is not None:
            raise bad_request(error)
        return self.paths[0]

    def subscription_path(self) -> str:
        """The path a subscription is created (or PATCHed: mongoUpdateSubscription.cpp) with."""
        if len(self.paths) > 1:
            raise bad_request(f"max *one* service-path allowed for subscriptions ({len(self.paths)} given)")
        return self.paths[0] if self.paths else EVERYTHING

    def subscription_filter(self) -> str | None:
        """The path subscription reads filter on: the header's first, as Orion's getSubscription.cpp
        and getAllSubscriptions.cpp pass ``servicePathV[0]``; None without the header."""
        return self.paths[0] if self.paths else None


@dataclass(frozen=True, slots=True)
class EntitySelector:
    """One element of a subscription's ``subject.entities`` or of an ``op/query``'s ``entities``:
    exactly one of id/idPattern, at most one of type/typePattern. A pattern matches anywhere in the
    string, as Orion's matching does (``regexec`` in cache/subCache.cpp, MongoDB's ``$regex`` in
    mongoBackend/MongoGlobal.cpp): ``robot`` matches ``robot_1``; anchor it (``^robot$``) for more."""

    id: str | None = None
    id_pattern: str | None = None
    type: str | None = None
    type_pattern: str | None = None

    def matches(self, entity: Entity) -> bool:
        if self.id is not None and entity.id != self.id:
            return False
        if self.id_pattern is not None and not re.search(self.id_pattern, entity.id):
            return False
        if self.type is not None and entity.type != self.type:
            return False
        return self.type_pattern is None or bool(re.search(self.type_pattern, entity.type))

    def render(self) -> dict[str, str]:
        keys = (("id", self.id), ("idPattern", self.id_pattern), ("type", self.type))
        out = {k: v for k, v in keys if v is not None}
        if self.type_pattern is not None:
            out["typePattern"] = self.type_pattern
        return out


def compiles(pattern: str) -> bool:
    try:
        re.compile(pattern)
    except (re.error, OverflowError, RecursionError):  # a{99999999999}: too large a repetition
        return False
    return True


def check_pattern(raw: Any, what: str) -> str:
    """A regular expression from a request (``idPattern``/``typePattern``), checked to compile."""
    if not isinstance(raw, str):
        raise bad_request(f"Invalid JSON type for entity {what}")
    if not raw or not compiles(raw):
        raise bad_request(f"Invalid regex for entity {what}")
    return str(raw)


def parse_subscription_selector(raw: Any) -> EntitySelector:
    """A ``subject.entities`` element, with the checks and words of Orion's
    jsonParseV2/parseEntitiesVector.cpp (in its order)."""
    if not isinstance(raw, dict):
        raise bad_request("/entities/ vector item is not an object")
    if "id" not in raw and "idPattern" not in raw:
        raise bad_request("/entities/ vector item does not have /id/ nor /idPattern/")
    if "id" in raw and "idPattern" in raw:
        raise bad_request("/entities/ vector item has both /id/ and /idPattern/")
    if "type" in raw and "typePattern" in raw:
        raise bad_request("/entities/ element has both /type/ and /typePattern/")
    fields: dict[str, str] = {}
    for key, field, what in (("id", "id", "/id/"), ("idPattern", "id_pattern", "/idPattern/"),
                             ("type", "type", "type"), ("typePattern", "type_pattern", "/typePattern/")):
        if key not in raw:
            continue
        value = raw[key]
        if not isinstance(value, str):
            raise bad_request(f"/entities/ vector item {what} is not a string")
        if key == "id":
            if not value:
                raise bad_request("/entities/ element id is empty")
            if not is_identifier(value):
                raise bad_request("forbidden characters in /entities/ vector item /id/")
            if len(value) > IDENTIFIER_MAX:
                raise bad_request("max id length exceeded in /entities/ vector item /id/")
        elif key == "type":
            if value and not is_identifier(value):
                raise bad_request("forbidden characters in /entities/ vector item /type/")
            if len(value) > IDENTIFIER_MAX:
                raise bad_request("max type length exceeded in /entities/ vector item /type/")
            if not value:
                raise bad_request("entity type length: 0, min length supported: 1")
        else:
            if not value:
                raise bad_request(f"/entities/ vector item /{key}/ is empty")
            if not compiles(value):
                raise bad_request(f"Invalid regex for entity {key}")
        fields[field] = value
    return EntitySelector(**fields)


def check_entity_object(raw: Any) -> dict[str, Any]:
    """The first checks of Orion's jsonParseV2/parseEntityObject.cpp, shared by ``op/query`` and
    ``op/update``: an object with exactly one of ``id`` and ``idPattern``."""
    if not isinstance(raw, dict):
        raise bad_request("entity is not a JSON object")
    if "id" in raw and "idPattern" in raw:
        raise bad_request("both /id/ and /idPattern/ present")
    if "id" not in raw and "idPattern" not in raw:
        raise bad_request("nor /id/ nor /idPattern/ present")
    return raw


def parse_query_selector(raw: Any) -> EntitySelector:
    """An ``op/query`` ``entities`` element, with the checks and words of Orion's
    jsonParseV2/parseEntityObject.cpp and ``Entity::check`` (apiTypesV2/Entity.cpp)."""
    raw = check_entity_object(raw)
    for key, value in raw.items():
        if key in ("id", "type"):
            if not isinstance(value, str):
                raise bad_request(f"Invalid JSON type for entity {key}")
            if key == "type" and not value:
                raise bad_request("entity type length: 0, min length supported: 1")
            if value and not is_identifier(value):
                raise bad_request(f"Invalid characters in entity {key}")
        elif key in ("idPattern", "typePattern"):
            if not isinstance(value, str):
                raise bad_request(f"Invalid JSON type for entity {key}")
            if not compiles(value):
                raise bad_request(f"Invalid regex for entity {key}")
        else:
            raise bad_request("no attributes allowed in Entity in this payload")
    if not raw.get("id") and not raw.get("idPattern"):
        raise bad_request("id and idPattern cannot be both empty at the same time")
    for key in ("id", "idPattern"):
        if len(raw.get(key) or "") > IDENTIFIER_MAX:
            raise bad_request(f"entity {key} length: {len(raw[key])}, max length supported: {IDENTIFIER_MAX}")
    if raw.get("typePattern") == "":
        raise bad_request("type and typePattern cannot be both empty at the same time")
    for key in ("type", "typePattern"):
        if len(raw.get(key) or "") > IDENTIFIER_MAX:
            raise bad_request(f"entity {key} length: {len(raw[key])}, max length supported: {IDENTIFIER_MAX}")
    return EntitySelector(raw.get("id"), raw.get("idPattern"), raw.get("type"), raw.get("typePattern"))
