"""docs/library.md runs as written (SPEC §9, issue 10 item 9): its ```python blocks, in order, in one
namespace, from the repository root; every ``test_`` function they define is then called.

Stand-in until the generic docs test (tests/test_docs.py) lands; then this file can go.
"""

from __future__ import annotations

import re

from tests.conftest import ROOT

BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)


def test_library_doc_blocks_run_verbatim(monkeypatch):
    monkeypatch.chdir(ROOT)
    text = (ROOT / "docs" / "library.md").read_text(encoding="utf-8")
    blocks = BLOCK.findall(text)
    assert len(blocks) >= 4
    namespace: dict = {"__name__": "docs_library"}
    for k, block in enumerate(blocks):
        exec(compile(block, f"docs/library.md block {k + 1}", "exec"), namespace)
    tests = [name for name in namespace if name.startswith("test_")]
    assert len(tests) >= 2
    for name in tests:
        namespace[name]()
