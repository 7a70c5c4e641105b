"""Orion-safe strings: a reversible percent escape of exactly the characters Orion forbids.

Orion rejects a request whose values contain ``< > " ' = ; ( )`` anywhere (vcran.core.orion_rules). vcran
escapes such strings rather than refusing them, because its own outbound text is full of them: error
messages (``must be 1..length=3``, ``(known: 0, 5, 10, 20)``) and ids' descriptions echoed from scenarios.
Orion's documentation recommends URL encoding for this; escaping ``%`` as well makes the mapping
reversible, so a description survives a round trip through Orion unchanged (docs/wire-format.md).
"""

from __future__ import annotations

import re

#: Orion's forbidden characters plus ``%`` itself, each written as ``%XX`` (upper-case hex).
ESCAPED = frozenset('<>"\'=;()%')
_ESCAPES = {ord(c): f"%{ord(c):02X}" for c in ESCAPED}
_UNESCAPE = re.compile(r"%(2[25789]|3[B-Eb-e])")


def escape_string(text: str) -> str:
    """Percent-encode exactly ``< > " ' = ; ( ) %``: Orion accepts the result, and it is reversible."""
    return text if ESCAPED.isdisjoint(text) else text.translate(_ESCAPES)


def unescape_string(text: str) -> str:
    """Undo :func:`escape_string` in one left-to-right pass; any other ``%`` sequence stays as it is.

    Applied to every decoded string, so a fleet manager that URL-encodes forbidden characters as Orion
    advises is understood too; ``%`` not followed by one of the nine codes is an ordinary character.
    """
    return _UNESCAPE.sub(lambda m: chr(int(m.group(1), 16)), text) if "%" in text else text
