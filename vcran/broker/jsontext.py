"""JSON as Orion reads and writes it: strict parsing, and numbers printed the way Orion prints doubles.

Orion keeps every number of an attribute or metadata value as a C ``double`` and prints it with its own
routine (``double2string`` in Orion's ``src/lib/common/string.cpp``), not with a shortest round-trip
formatter: at most nine decimals, trailing zeros cut, and a value within about 1e-9 of an integer
printed as that integer. So ``1.5707963267948966`` reads back ``1.570796327``, ``1e-10`` reads back
``0`` and ``80.0`` reads back ``80``. :func:`double_text` reproduces that routine case by case, quirks
included, because a live run through this broker should see the numbers a real Orion gives:

* the fraction test uses C's truncating cast, so for a negative number just above an integer the
  rounding goes the wrong way: ``-2.99999999999`` prints ``-1``, as in Orion;
* magnitudes of 2**63 and more overflow that cast; Orion then prints ``%.17g`` and cuts trailing
  zeros of the exponent too: ``1e20`` prints ``1e+2``, as in Orion.

Numbers inside vcran's messages are far from both. The broker stores attribute and metadata numbers as
floats (:func:`as_double`), so integers beyond 2**53 lose precision exactly as they do in Orion.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable
from json.encoder import encode_basestring
from typing import Any

#: C's ``(long long) f`` is defined for -2**63 <= f < 2**63; beyond, x86-64 gives INT64_MIN.
_INT64_MIN = -(2**63)


def double_text(f: float) -> str:
    """The text Orion 4.7 prints for the double ``f`` (finite)."""
    whole = int(f) if _INT64_MIN <= f < -_INT64_MIN else _INT64_MIN
    diff = abs(f - whole)
    if diff > 1:  # the cast overflowed: a huge magnitude
        text = f"{f:.17g}"
    elif diff > 0.9999999998:
        return str(whole + 1)
    elif diff < 0.000000001:
        return str(whole)
    else:
        text = f"{f:.9f}"
    text = text.rstrip("0") or text[0]  # Orion cuts trailing zeros (of an exponent too), never the first
    return text[:-1] if text.endswith(".") else text


def as_double(value: Any) -> Any:
    """``value`` with every number as the double Orion stores (booleans stay booleans)."""
    if isinstance(value, float):
        return value
    if isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if isinstance(value, dict):
        return {k: as_double(v) for k, v in value.items()}
    if isinstance(value, list):
        return [as_double(v) for v in value]
    return value


def render_json(value: Any) -> bytes:
    """Compact JSON as Orion writes it: no spaces, non-ASCII characters kept as UTF-8, floats as
    :func:`double_text` (ints, such as counters, as they are)."""
    parts: list[str] = []
    _render(value, parts.append)
    return "".join(parts).encode()


def _render(value: Any, out: Callable[[str], object]) -> None:
    if isinstance(value, str):
        out(encode_basestring(value))
    elif isinstance(value, dict):
        out("{")
        for i, (key, item) in enumerate(value.items()):
            if i:
                out(",")
            out(encode_basestring(key))
            out(":")
            _render(item, out)
        out("}")
    elif isinstance(value, list | tuple):
        out("[")
        for i, item in enumerate(value):
            if i:
                out(",")
            _render(item, out)
        out("]")
    elif value is None:
        out("null")
    elif value is True:
        out("true")
    elif value is False:
        out("false")
    elif isinstance(value, float):
        out(double_text(value))
    elif isinstance(value, int):
        out(str(value))
    else:
        raise TypeError(f"cannot render {type(value).__name__} as JSON")


# --- parsing --------------------------------------------------------------------------------------------

#: A ``\\u`` escape of a UTF-16 surrogate; only such an escape can put a surrogate into parsed JSON.
_SURROGATE_ESCAPE = re.compile(r"\\u[dD][89a-fA-F]")


def _reject_constant(name: str) -> Any:
    raise ValueError(f"{name} is not JSON")


def _finite_float(text: str) -> float:
    number = float(text)
    if not math.isfinite(number):  # 1e400: Orion's parser refuses a number no double can hold
        raise ValueError(f"number {text[:20]} is too big")
    return number


def _finite_int(text: str) -> int:
    _finite_float(text)
    return int(text)  # more than 4300 digits: ValueError too


def parse_json(body: bytes) -> Any:
    """Strict JSON, as Orion's parser reads it: UTF-8 only; ``NaN``/``Infinity`` and numbers beyond a
    double's range are errors, and so is a lone UTF-16 surrogate (``"\\udc00"``: valid JSON syntax, but
    no string Orion can store or print). Raises ValueError (or RecursionError for absurd nesting)."""
    text = body.decode("utf-8")
    value = json.loads(text, parse_constant=_reject_constant, parse_float=_finite_float, parse_int=_finite_int)
    if _SURROGATE_ESCAPE.search(text) and _has_lone_surrogate(value):  # a pair decodes to one character
        raise ValueError("a lone UTF-16 surrogate is not a Unicode string")
    return value


def _has_lone_surrogate(value: Any) -> bool:
    if isinstance(value, str):
        return not value.isascii() and any("\ud800" <= c <= "\udfff" for c in value)
    if isinstance(value, dict):
        return any(_has_lone_surrogate(k) or _has_lone_surrogate(v) for k, v in value.items())
    if isinstance(value, list):
        return any(map(_has_lone_surrogate, value))
    return False
