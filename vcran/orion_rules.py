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
