"""Orion's syntax restrictions, as data and small pure checks.

Written from Orion's documentation ("Forbidden characters", "Identifiers syntax restrictions") and checked
against the exchanges recorded with a real Orion 4.7 (tests/data/orion-4.7-exchanges.jsonl). Two users:
the codec, which must never produce a value Orion rejects, and vcran's own broker, which must reject what
Orion rejects with the same error description.
"""

from __future__ import annotations

from typing import Any

#: Characters Orion rejects in attribute values (anywhere inside a compound value) and in identifiers.
FORBIDDEN_CHARS = frozenset('<>"\'=;()')
#: Further characters not allowed in identifiers (entity id/type, attribute and metadata name/type).
IDENTIFIER_EXTRA_FORBIDDEN = frozenset("&?/#")
IDENTIFIER_MAX = 256
#: Orion's default ``-inReqPayloadMaxSize``: larger requests are answered 413.
MAX_REQUEST_BYTES = 1_048_576
#: Fiware-Service: only alphanumerics and underscore, at most 50 characters; case-insensitive.
TENANT_MAX = 50


def identifier_error(kind: str, name: Any) -> str | None:
    """Orion's error description for an invalid identifier, or None when it is valid.

    ``kind`` is how Orion names the field in its messages: ``entity id``, ``entity type``,
    ``attribute name``, ``attribute type``, ``metadata name`` or ``metadata type``.
    """
    if not isinstance(name, str):
        return f"Invalid JSON type for {kind}"
    if len(name) < 1:
        return f"{kind} length: 0, min length supported: 1"
    if len(name) > IDENTIFIER_MAX:
        return f"{kind} length: {len(name)}, max length supported: {IDENTIFIER_MAX}"
    if not is_identifier(name):
        return f"Invalid characters in {kind}"
    return None


def is_identifier(name: str) -> bool:
    """Plain printable ASCII without whitespace, ``& ? / #`` or a forbidden character."""
    return all(
        "!" <= c <= "~" and c not in FORBIDDEN_CHARS and c not in IDENTIFIER_EXTRA_FORBIDDEN for c in name
    )


def has_forbidden_chars(value: Any) -> bool:
    """True when a string anywhere inside ``value`` (a JSON value) holds a forbidden character."""
    stack = [value]
    while stack:
        v = stack.pop()
        if isinstance(v, str):
            if not FORBIDDEN_CHARS.isdisjoint(v):
                return True
        elif isinstance(v, dict):
            stack.extend(v.values())
        elif isinstance(v, list):
            stack.extend(v)
    return False


# --- Multi-tenancy and service paths (Orion's "multitenancy" and "service_path" manual pages) ------------

#: At most this many comma-separated service paths in a query's Fiware-ServicePath (only one in updates).
SERVICE_PATH_MAX_PATHS = 10
#: At most this many levels in one service path, each of 1..50 alphanumerics or underscores.
SERVICE_PATH_MAX_LEVELS = 10
SERVICE_PATH_MAX_COMPONENT = 50


def tenant_error(tenant: str) -> str | None:
    """Orion's description for an invalid ``Fiware-Service``, or None when it is valid.

    Orion lower-cases the tenant before use, so ``Plant_A`` and ``plant_a`` are one tenant.
    """
    if len(tenant) > TENANT_MAX:
        return f"bad length - a tenant name can be max {TENANT_MAX} characters long"
    if not all(c.isascii() and (c.isalnum() or c == "_") for c in tenant):
        return "bad character in tenant name - only underscore and alphanumeric characters are allowed"
    return None


def split_service_paths(header: str) -> list[str]:
    """The comma-separated paths of a ``Fiware-ServicePath`` header, stripped, trailing slashes removed."""
    paths = []
    for raw in header.split(","):
        path = raw.strip()
        while len(path) > 1 and path.endswith("/"):
            path = path[:-1]
        paths.append(path)
    return paths


def service_path_error(path: str) -> str | None:
    """Orion's description for an invalid service path in any request, or None when it is valid.

    The last level may be exactly ``#`` (recursive, for queries and subscriptions); an update forbids it
    separately (:func:`update_service_path_error`).
    """
    if not path.startswith("/"):
        return "Only /absolute/ Service Paths allowed [a service path must begin with /]"
    if path == "/":
        return None
    levels = path[1:].split("/")
    if len(levels) > SERVICE_PATH_MAX_LEVELS:
        return "too many components in ServicePath"
    for i, level in enumerate(levels):
        if len(level) > SERVICE_PATH_MAX_COMPONENT:
            return "component-name too long in ServicePath"
        if not level:
            return "empty component in ServicePath"
        if level == "#" and i == len(levels) - 1:
            continue
        if not all(c.isascii() and (c.isalnum() or c == "_") for c in level):
            return "a component of ServicePath contains an illegal character"
    return None


def update_service_path_error(path: str) -> str | None:
    """The stricter rule for requests that write entities: one plain path, no ``#`` and no comma."""
    if not all(c.isascii() and (c.isalnum() or c in "_/") for c in path):
        return "Bad Character in Service-Path"
    return None


def default_attribute_type(value: Any) -> str:
    """The type Orion gives an attribute or metadata written without one, from its JSON value."""
    if isinstance(value, bool):
        return "Boolean"
    if isinstance(value, (int, float)):
        return "Number"
    if isinstance(value, str):
        return "Text"
    if value is None:
        return "None"
    return "StructuredValue"
