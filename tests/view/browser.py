"""A real headless browser for the page's tests (docs/contract.md §13, issue 33 item 4): the system's Chromium, driven
by Playwright for Python (which never downloads a browser of its own here: it launches the one given).

Where no Chromium is installed, the browser tests are skipped with the reason, except in CI (the ``CI``
environment variable set, as CI runs ``.ci/run`` with ``CI=true``), where a missing browser fails them:
CI must install it. ``VCRAN_CHROMIUM`` names another Chromium binary.
"""

from __future__ import annotations

import os
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

#: Flags for a quiet, sandbox-free headless run that reaches for nothing on its own (no updates, sync or
#: background requests).
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
        "--disable-component-update", "--disable-sync", "--no-first-run"]
VIEWPORT = {"width": 1400, "height": 800}


def in_ci() -> bool:
    return os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


def chromium() -> str | None:
    return os.environ.get("VCRAN_CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")


def unavailable() -> str | None:
    """Why no browser test can run here, or None."""
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "Playwright for Python is not installed (pip install -e '.[test]')"
    if chromium() is None:
        return "no Chromium on this machine (apt-get install chromium, or set VCRAN_CHROMIUM to its binary)"
    return None


@dataclass
class Page:
    """A page opened in the browser, with everything it said and asked for."""

    page: Any
    console: list[tuple[str, str]] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)
    requests: list[str] = field(default_factory=list)

    def js(self, expression: str, arg: Any = None) -> Any:
        return self.page.evaluate(expression, arg)

    @property
    def problems(self) -> list[str]:
        """Console errors and warnings, and uncaught exceptions."""
        return [f"{kind}: {text}" for kind, text in self.console if kind in ("error", "warning")] + self.errors

    def canvas_png(self) -> bytes:
        return self.page.locator("#floor").screenshot()


def open_page(browser: Any, url: str, viewport: dict[str, int] = VIEWPORT) -> Page:
    """Open ``url`` (a file:// or http:// address) and wait until the page has decoded its data."""
    page = browser.new_page(viewport=viewport)
    opened = Page(page)
    page.on("console", lambda m: opened.console.append((m.type, m.text)))
    page.on("pageerror", lambda e: opened.errors.append(str(e)))
    page.on("request", lambda r: opened.requests.append(r.url))
    page.goto(url)
    page.evaluate("window.vcranView.ready")
    return opened


def file_url(path: Path) -> str:
    return path.resolve().as_uri()
