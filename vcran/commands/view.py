"""``vcran view RUN [--out PAGE.html] [--open]``: a run folder as one page that opens from disk (docs/contract.md §13).

The page (docs/view.md) holds its scripts, styles and the run's data: it fetches nothing and needs no
server. By default it is written into the run folder as ``view.html`` (as ``vcran run --view`` does); a
folder still being written (``<out>.incomplete``: a live run under way, or one killed) is not written
into, so it needs ``--out``.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from vcran.commands import CommandError

if TYPE_CHECKING:
    from vcran.view.live import LiveView

HELP = "write a run's folder as one interactive page (floor, robots moving, jobs, incidents) that opens from disk"
PAGE = "view.html"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("dir", type=Path, metavar="RUN",
                        help="a run folder: of vcran run, replay, live or manage (--out)")
    parser.add_argument("--out", type=Path, metavar="PAGE.html", help=f"the page to write (default: RUN/{PAGE})")
    parser.add_argument("--open", action="store_true", help="then open the page in the default web browser")
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors")


def run(args: argparse.Namespace) -> int:
    from vcran.io.runfolder import INCOMPLETE

    out = args.out
    if out is None:
        if args.dir.name.endswith(INCOMPLETE):
            raise CommandError(f"{args.dir}: a run still being written (or killed): give the page's path with --out")
        out = args.dir / PAGE
    if out.is_dir():
        raise CommandError(f"{out}: is a folder; --out names the page's file, e.g. {out / PAGE}")
    page = write(args.dir, out, quiet=args.quiet)
    if args.open:
        import webbrowser

        if not webbrowser.open(page.resolve().as_uri()):
            print(f"vcran view: no web browser found; open {page} yourself")
    return 0


def write(run_dir: Path, out: Path, quiet: bool = False) -> Path:
    """Write the page of ``run_dir`` to ``out`` and say where (unless quiet); a folder that cannot be shown
    is a CommandError: one line on stderr, exit status 2."""
    from vcran.view import ViewError, write_page

    try:
        page = write_page(run_dir, out)
    except ViewError as exc:
        raise CommandError(str(exc)) from None
    if not quiet:
        print(f"page in {page} ({page.stat().st_size / 1e6:.1f} MB): open it in a web browser")
    return page


def add_live_argument(parser: argparse.ArgumentParser) -> None:
    """``--view PORT`` of ``vcran live`` and ``vcran manage``."""
    parser.add_argument("--view", type=int, metavar="PORT",
                        help="serve the run's page (as vcran view writes it) on 127.0.0.1:PORT, following the run "
                             "as it goes (docs/view.md); needs --out")


def check_view(port: int | None, out: Path | None) -> None:
    """Refuse a ``--view`` that cannot work, before the command opens anything."""
    if port is None:
        return
    if out is None:
        raise CommandError("--view shows the run folder as it is written: give --out")
    if not 0 < port < 65536:
        raise CommandError(f"--view takes a port number, 1-65535, got {port}")


def serve_live(port: int | None, out: Path | None, quiet: bool = False) -> LiveView | None:
    """The live page of the run being written into ``out`` on 127.0.0.1:``port`` (None: no --view); a port
    that cannot be bound is a CommandError."""
    check_view(port, out)
    if port is None or out is None:
        return None
    from vcran.view.live import LiveView, live_folder

    try:
        view = LiveView(live_folder(out), port)
    except OSError as exc:
        raise CommandError(f"cannot serve the view on 127.0.0.1:{port}: {exc.strerror}") from None
    if not quiet:
        print(f"view: {view.url} (follows the run as it goes)", flush=True)
    return view


def end_live(view: LiveView | None) -> None:
    """The run has ended: the page gets its last state before the server stops."""
    if view is not None:
        view.finish()
        view.close()
