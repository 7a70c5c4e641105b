"""The view's tests: a real headless browser (tests/view/browser.py says where it comes from and when the
browser tests are skipped)."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from tests.view.browser import ARGS, chromium, in_ci, unavailable


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    reason = unavailable()
    if reason is not None:
        if in_ci():
            pytest.fail(f"CI runs the browser tests (docs/contract.md §13), but {reason}")
        pytest.skip(f"the page's browser tests need a browser: {reason}")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=chromium(), args=ARGS)
        yield b
        b.close()
