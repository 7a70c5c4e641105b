"""The page: one HTML file with its styles, scripts and the run's data inline (docs/contract.md §13).

The scripts are plain JavaScript, one file per concept under ``assets/`` (readable as they are; no build
step, no library), concatenated in :data:`SCRIPTS` order into one ``<script>``; the data is
:func:`vcran.view.pack.payload`'s base64 in a ``<script type="application/octet-stream">``, which the
browser does not run. The page's Content-Security-Policy forbids every fetch but its own origin (what a
live page's event stream needs), so a page opened from disk cannot reach the network even by mistake.
"""

from __future__ import annotations

from importlib import resources

#: The scripts in the order they load: each uses only those before it.
SCRIPTS = ("data.js", "kinematics.js", "fleet.js", "status.js", "floor.js", "timeline.js", "panels.js", "app.js")


def asset(name: str) -> str:
    return (resources.files("vcran.view") / "assets" / name).read_text(encoding="utf-8")


def html(payload: str, extra_scripts: tuple[str, ...] = ()) -> str:
    """The page around ``payload`` (base64, :mod:`vcran.view.pack`); ``extra_scripts`` are loaded last
    (the live page's)."""
    script = "\n".join(f"// --- {name} ---\n{asset(name)}" for name in (*SCRIPTS, *extra_scripts))
    if "</script" in script.lower():
        raise AssertionError("a view script holds '</script', which would end the page's script early")
    page = asset("page.html")
    for marker, text in (("/*STYLE*/", asset("style.css")), ("/*SCRIPT*/", script), ("/*DATA*/", payload)):
        head, found, tail = page.partition(marker)
        if not found:
            raise AssertionError(f"page.html has no {marker}")
        page = head + text + tail
    return page
