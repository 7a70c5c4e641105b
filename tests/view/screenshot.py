"""docs/view.png, the page's screenshot in docs/view.md, made by the test suite's browser (issue 33 item 6).

``.venv/bin/python -m tests.view.screenshot`` rewrites docs/view.png: the warehouse's closed loop, job 41
selected, at the cursor the job moved it to. tests/view/test_view_docs.py makes the same picture in a
temporary folder and checks that the committed one still matches it.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path
from typing import Any

import vcran.testing.pytest_plugin  # noqa: F401  (the hypothesis profile tests/conftest.py loads, outside pytest)
from tests.conftest import ROOT
from tests.view.browser import ARGS, chromium, file_url, open_page
from tests.view.runs import bundled
from vcran.view import write_page

PICTURE = ROOT / "docs" / "view.png"
SIZE = {"width": 1280, "height": 720}
JOB = "job_41"


def screenshot(browser: Any, folder: Path, out: Path) -> list[str]:
    """Run the warehouse into ``folder``, open its page, select :data:`JOB` and write the picture to ``out``;
    returns what the page logged as errors or warnings (none expected)."""
    run = bundled("warehouse", folder / "warehouse")
    page = open_page(browser, file_url(write_page(run, folder / "warehouse.html")), viewport=SIZE)
    page.page.locator('#tabs button[data-tab="jobs"]').click()
    page.page.locator(f'#jobs tr[data-job="{JOB}"]').click()
    page.page.screenshot(path=str(out))
    page.page.close()
    return page.problems


def main() -> int:
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p, tempfile.TemporaryDirectory() as tmp:
        browser = p.chromium.launch(executable_path=chromium(), args=ARGS)
        problems = screenshot(browser, Path(tmp), PICTURE)
        browser.close()
    print(f"wrote {PICTURE}" + (f"; the page logged {problems}" if problems else ""))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
