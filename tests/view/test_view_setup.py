"""When the browser tests run (issue 33 item 4): with a Chromium, always; without one, skipped with the
reason on a user's machine, failed in CI (tests/view/browser.py)."""

from __future__ import annotations

import pytest

from tests.view import browser


@pytest.mark.parametrize(("value", "ci"), [(None, False), ("", False), ("false", False), ("0", False),
                                          ("true", True), ("1", True), ("yes", True)])
def test_ci_is_the_ci_variable_set(monkeypatch, value, ci):
    if value is None:
        monkeypatch.delenv("CI", raising=False)
    else:
        monkeypatch.setenv("CI", value)
    assert browser.in_ci() is ci


def test_without_chromium_the_reason_names_it(monkeypatch):
    monkeypatch.delenv("VCRAN_CHROMIUM", raising=False)
    monkeypatch.setenv("PATH", "/nonexistent")
    assert browser.chromium() is None
    assert "no Chromium on this machine" in browser.unavailable()
    monkeypatch.setenv("VCRAN_CHROMIUM", "/opt/my/chromium")
    assert browser.chromium() == "/opt/my/chromium" and browser.unavailable() is None
