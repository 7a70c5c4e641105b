"""docs/vda5050.md's "Live over MQTT" section runs as written, its printed output as shown, the live
example against a real Mosquitto (its URL, mqtt://127.0.0.1:1883, replaced by the test broker's)."""

from __future__ import annotations

import io
from contextlib import redirect_stdout

from tests.conftest import ROOT
from tests.test_docs import blocks

DOC = ROOT / "docs" / "vda5050.md"
SECTION = "## Live over MQTT"


def _section_blocks():
    text = DOC.read_text(encoding="utf-8")
    start = text.index(SECTION)
    end = text.find("\n## ", start + 1)
    first = text[:start].count("\n") + 1
    last = text[:end].count("\n") + 1 if end != -1 else text.count("\n") + 2
    return [b for b in blocks(DOC) if first <= b.line <= last]


def test_the_live_example_runs_against_mosquitto(broker):
    found = _section_blocks()
    python = [i for i, b in enumerate(found) if b.lang == "python"]
    assert len(python) == 2 and found[python[1]].tested_by is not None
    namespace: dict[str, object] = {"__name__": "__docs__"}
    for i in python:
        code = found[i].code.replace("mqtt://127.0.0.1:1883", broker.url)
        printed = io.StringIO()
        with redirect_stdout(printed):
            exec(compile("\n" * (found[i].line - 1) + code, str(DOC), "exec"), namespace)  # noqa: S102
        shown = found[i + 1]
        assert shown.lang == "text" and printed.getvalue().rstrip() == shown.code.rstrip(), f"{shown}"
