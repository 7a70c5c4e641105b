"""``vcran view``: a run folder as one interactive page that opens from disk (docs/contract.md §13, docs/view.md).

:func:`write_page` reads the folder (:mod:`.folder`), turns it into the page's protocol-neutral model
(:mod:`.build`, :mod:`.model`), packs it (:mod:`.pack`) and writes it into the page (:mod:`.page`)
together with the scripts under ``assets/``, which draw the floor, evaluate every robot's legs at the
cursor exactly as the run did, and show the robots', jobs' and incidents' panels.
"""

from __future__ import annotations

from pathlib import Path

from vcran.view.folder import ViewError

__all__ = ["ViewError", "page_html", "write_page"]


def page_html(run: Path) -> str:
    """The page of the run folder ``run``, as text; :class:`ViewError` when the folder cannot be shown."""
    from vcran.view.build import build_model
    from vcran.view.folder import read_folder
    from vcran.view.pack import payload
    from vcran.view.page import html

    return html(payload(build_model(read_folder(run))))


def write_page(run: Path, out: Path) -> Path:
    """Write the page of ``run`` to ``out`` (replaced whole: written beside it, then renamed)."""
    text = page_html(run)
    out.parent.mkdir(parents=True, exist_ok=True)
    staging = out.with_name(out.name + ".partial")
    staging.write_text(text, encoding="utf-8")
    staging.replace(out)
    return out
