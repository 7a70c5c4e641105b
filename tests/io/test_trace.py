"""The trace's JSON rendering (vcran.io.trace.dumps): orjson walks message dataclasses natively, and its
output must equal the plain form the rest of vcran reads and writes (vcran.core.plain.to_plain)."""

from __future__ import annotations

import json
from typing import Any

from hypothesis import given

from vcran.core.plain import to_plain
from vcran.io.trace import dumps
from vcran.testing.strategies import attribute_messages


@given(attribute_messages())
def test_a_message_renders_as_its_plain_form(pair: tuple[str, Any]) -> None:
    _, message = pair
    assert json.loads(dumps(message)) == to_plain(message)
    assert json.loads(dumps({"v": [message, message]})) == {"v": [to_plain(message)] * 2}  # the memo path
