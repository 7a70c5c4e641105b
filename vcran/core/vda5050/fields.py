"""How a model's field meets the wire: the few fields whose JSON name is not their camelCase, or which
exist in one protocol version only. Read by :mod:`vcran.core.vda5050.codec`; the models declare it here.

A field's JSON name is its Python name in camelCase (``order_update_id`` -> ``orderUpdateId``) unless
:func:`wire` says otherwise. Where 2.0.0 and 2.1.0 differ (docs/vda5050.md, "Versions"), the difference is
declared on the field, so the codec has no per-message special cases.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

from vcran.core.vda5050.enums import Version

_NO_DEFAULT: Any = dataclasses.MISSING


def wire(
    default: Any = _NO_DEFAULT,
    *,
    name: str | None = None,
    v2_0: str | None = None,
    since: Version | None = None,
    flatten: bool = False,
    no_object_before: Version | None = None,
    v2_0_check: Callable[[Any], str | None] | None = None,
    v2_0_alias: str | None = None,
) -> Any:
    """A dataclass field with wire metadata.

    ``name``: the JSON name (both versions); ``v2_0``: the 2.0.0 spelling where it differs;
    ``since``: the field does not exist before that version (not read, and an error to send);
    ``flatten``: a nested model whose fields sit in the enclosing object (the header, §6.4);
    ``no_object_before``: a JSON value that may be an object only from that version on (action parameter
    values); ``v2_0_check``: for a nested model that 2.0.0 constrains more here than elsewhere (a
    nodeState's ``nodePosition`` needs ``theta``), a function returning the path of a missing part below
    it, or None; ``v2_0_alias``: another name read (never written) in 2.0.0 messages.
    """
    meta = {
        "name": name, "v2_0": v2_0, "since": since, "flatten": flatten, "no_object_before": no_object_before,
        "v2_0_check": v2_0_check, "v2_0_alias": v2_0_alias,
    }
    if default is _NO_DEFAULT:
        return dataclasses.field(metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def camel(name: str) -> str:
    """``order_update_id`` -> ``orderUpdateId``."""
    head, *rest = name.split("_")
    return head + "".join(part[:1].upper() + part[1:] for part in rest)
