"""Tenants (``Fiware-Service``) and service paths (``Fiware-ServicePath``): which entities a request sees.

Orion's rules (manual: multitenancy, service_path; confirmed by the recordings):

- a tenant is an isolated database; its name is case-insensitive (``Plant_A`` is ``plant_a``); no
  header means the default tenant;
- an entity belongs to exactly one service path, ``/`` when created without the header;
- a query without the header sees every path (``/#``); ``/a`` sees only ``/a``, not ``/a/b`` nor ``/``;
  ``/a/#`` sees ``/a`` and everything below it; a comma-separated list sees the union;
- a write names one plain path; without the header it creates in ``/`` and finds existing entities
  in any path;
- a subscription's path selects the entities it watches, ``/#`` when created without the header.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

from vcran.broker.model import Entity
from vcran.broker.protocol import Request, bad_request
from vcran.core.orion_rules import (
    SERVICE_PATH_MAX_PATHS,
    identifier_error,
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
        (:meth:`check_tenant`), in the order Orion reports them."""
        header = request.header("Fiware-ServicePath")
        paths: tuple[str, ...] = ()
        if header is not None and header.strip():
            paths = tuple(split_service_paths(header))
            if len(paths) > SERVICE_PATH_MAX_PATHS:
                raise bad_request("too many service paths - a maximum of ten service paths is allowed")
            for path in paths:
                error = service_path_error(path)
                if error is not None:
                    raise bad_request(error)
        return cls((request.header("Fiware-Service") or "").lower(), paths)

    def check_tenant(self) -> None:
        error = tenant_error(self.tenant)
        if error is not None:
            raise bad_request(error)

    def sees(self, entity_path: str) -> bool:
        """Query semantics: does this request see an entity in ``entity_path``?"""
        return any(path_covers(p, entity_path) for p in self.paths or (EVERYTHING,))

    def write_path(self) -> str | None:
        """The one path a write names (None: no header), after Orion's stricter check for writes."""
        if not self.paths:
            return None
        if len(self.paths) > 1:
            raise bad_request("Bad Character in Service-Path")
        error = update_service_path_error(self.paths[0])
        if error is not None:
            raise bad_request(error)
        return self.paths[0]

    def subscription_path(self) -> str:
        if len(self.paths) > 1:
            raise bad_request("max *one* service-path allowed for subscriptions")
        return self.paths[0] if self.paths else EVERYTHING


@dataclass(frozen=True, slots=True)
class EntitySelector:
    """One element of a subscription's ``subject.entities`` or of an ``op/query``'s ``entities``:
    exactly one of id/idPattern, at most one of type/typePattern; patterns match the whole string."""

    id: str | None = None
    id_pattern: str | None = None
    type: str | None = None
    type_pattern: str | None = None

    def matches(self, entity: Entity) -> bool:
        if self.id is not None and entity.id != self.id:
            return False
        if self.id_pattern is not None and not re.fullmatch(self.id_pattern, entity.id):
            return False
        if self.type is not None and entity.type != self.type:
            return False
        return self.type_pattern is None or bool(re.fullmatch(self.type_pattern, entity.type))

    def render(self) -> dict[str, str]:
        keys = (("id", self.id), ("idPattern", self.id_pattern), ("type", self.type))
        out = {k: v for k, v in keys if v is not None}
        if self.type_pattern is not None:
            out["typePattern"] = self.type_pattern
        return out


def check_pattern(raw: Any, what: str) -> str:
    """A regular expression from a request (``idPattern``/``typePattern``), checked to compile."""
    if not isinstance(raw, str):
        raise bad_request(f"Invalid JSON type for entity {what}")
    try:
        re.compile(raw)
    except (re.error, OverflowError, RecursionError):  # a{99999999999}: too large a repetition
        raise bad_request(f"Invalid regex for entity {what}") from None
    if not raw:
        raise bad_request(f"Invalid regex for entity {what}")
    return str(raw)


def parse_selector(raw: Any) -> EntitySelector:
    if not isinstance(raw, dict):
        raise bad_request("entities element is not an object")
    if ("id" in raw) == ("idPattern" in raw):
        raise bad_request("entities element must have exactly one of /id/ and /idPattern/")
    if "type" in raw and "typePattern" in raw:
        raise bad_request("entities element has both /type/ and /typePattern/")
    for key, kind in (("id", "entity id"), ("type", "entity type")):
        if key in raw and (error := identifier_error(kind, raw[key])) is not None:
            raise bad_request(error)
    return EntitySelector(
        id=raw.get("id"),
        id_pattern=check_pattern(raw["idPattern"], "idPattern") if "idPattern" in raw else None,
        type=raw.get("type"),
        type_pattern=check_pattern(raw["typePattern"], "typePattern") if "typePattern" in raw else None,
    )
