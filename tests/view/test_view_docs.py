"""docs/view.md's screenshot is the page as the suite's browser draws it (issue 33 item 6): remade here and
compared with the committed docs/view.png (``python -m tests.view.screenshot`` rewrites it)."""

from __future__ import annotations

import numpy as np

from tests.view.screenshot import PICTURE, SIZE, screenshot


def test_the_committed_screenshot_is_the_page_as_drawn_today(browser, tmp_path):
    from PIL import Image

    out = tmp_path / "view.png"
    assert screenshot(browser, tmp_path, out) == []
    made, committed = Image.open(out).convert("RGB"), Image.open(PICTURE).convert("RGB")
    assert made.size == committed.size == (SIZE["width"], SIZE["height"])
    # Fonts and antialiasing may differ by a shade between machines; the picture may not: pixels that differ
    # by more than a few levels must be few (a moved panel, a changed colour or layout is far above this)
    differ = np.abs(np.asarray(made, dtype=int) - np.asarray(committed, dtype=int)).max(axis=2) > 48
    assert differ.mean() < 0.02, "docs/view.png is out of date: python -m tests.view.screenshot rewrites it"
