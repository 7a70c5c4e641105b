"""The page of a run as it goes (docs/contract.md §13, issue 33 item 3): ``vcran live``/``vcran manage ... --view PORT``.

The interface is the run's recording: a live run writes its folder (``<out>.incomplete`` while it runs,
``<out>`` once it has ended) and hands every file to the operating system at each telemetry tick, so that
a run killed outright keeps its recording (docs/outputs.md). :class:`LiveView` watches that folder,
whichever command writes it and however it is wired, and serves on 127.0.0.1:

* ``/``: the same page ``vcran view`` writes, with the run so far, plus ``live.js``;
* ``/events``: server-sent events, one message per change of the folder, each the whole run so far as
  the page's payload (:mod:`vcran.view.pack`): the page swaps it in, following the end unless the user
  moved the slider back to look at an earlier instant.

Rebuilding the whole model per message keeps the page and the server simple and exact (the page has one
way to get data), at a cost that grows with the run: the folder is looked at every ``interval`` wall
seconds, and a rebuild that took long spaces the next one out (at most a tenth of the time is spent
rebuilding), which suits the fleets a person watches in real time.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

from vcran.view.folder import ViewError

log = logging.getLogger("vcran.view")

#: Wall seconds between looks at the folder, and between keep-alive comments on an idle event stream.
INTERVAL = 1.0
KEEPALIVE = 15.0
#: Wall seconds the server stays up after a run's end for the open pages to receive its last state.
FINISH_GRACE = 1.0


def live_folder(out: Path) -> Callable[[], Path | None]:
    """Where a run into ``out`` is: ``<out>.incomplete`` while it runs, ``out`` once it has ended."""
    from vcran.io.runfolder import INCOMPLETE

    running = out.with_name(out.name + INCOMPLETE)

    def where() -> Path | None:
        for path in (running, out):
            if path.is_dir():
                return path
        return None

    return where


class LiveView:
    """Serve the page of the run recorded at ``folder()`` on ``host:port`` (module docstring)."""

    def __init__(self, folder: Callable[[], Path | None], port: int, host: str = "127.0.0.1",
                 interval: float = INTERVAL) -> None:
        self._folder, self._interval = folder, interval
        self._payload: str | None = None
        self._version = 0
        self._signature: tuple[Any, ...] | None = None
        self._changed = threading.Condition()
        self._refreshing = threading.Lock()  # one rebuild at a time: the watcher's, or a page request's first
        self._stop = threading.Event()
        self._server = ThreadingHTTPServer((host, port), _handler(self))
        self._server.daemon_threads = True
        self._threads = [threading.Thread(target=self._server.serve_forever, name="vcran-view-http", daemon=True),
                         threading.Thread(target=self._watch, name="vcran-view-watch", daemon=True)]
        for thread in self._threads:
            thread.start()

    @property
    def url(self) -> str:
        host, port = self._server.server_address[:2]
        return f"http://{host!s}:{port}/"

    def finish(self, grace: float = FINISH_GRACE) -> None:
        """The run has ended: send its final state, and give the pages open on it a moment to receive it."""
        if self.refresh():
            self._stop.wait(grace)

    def close(self) -> None:
        """Stop watching and serving; the event streams end."""
        self._stop.set()
        with self._changed:
            self._changed.notify_all()
        self._server.shutdown()
        self._server.server_close()
        for thread in self._threads:
            thread.join(timeout=5)

    def __enter__(self) -> LiveView:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- the watcher ---------------------------------------------------------------------------------------

    def _watch(self) -> None:
        while not self._stop.is_set():
            started = time.monotonic()
            try:
                self.refresh()
            except Exception:  # a folder caught mid-write in a way the readers do not expect: look again later
                log.warning("live view: the run folder did not read; trying again", exc_info=True)
            spent = time.monotonic() - started
            self._stop.wait(max(self._interval, 9 * spent))

    def refresh(self) -> bool:
        """Rebuild the payload if the folder changed since the last look; whether it did."""
        with self._refreshing:
            return self._refresh()

    def _refresh(self) -> bool:
        folder = self._folder()
        signature = _signature(folder)
        if folder is None or signature == self._signature:
            return False
        from vcran.view.build import build_model
        from vcran.view.folder import read_folder
        from vcran.view.pack import payload

        try:
            text = payload(build_model(read_folder(folder)))
        except ViewError as exc:  # not written far enough yet (no header line): the next look will do
            log.debug("live view: %s", exc)
            return False
        with self._changed:
            self._payload, self._signature = text, signature
            self._version += 1
            self._changed.notify_all()
        return True

    def page(self) -> str:
        from vcran.view.page import html

        if self._payload is None:
            self.refresh()
        with self._changed:
            payload = self._payload
        if payload is None:
            raise ViewError("the run has not written its folder yet")
        return html(payload, extra_scripts=("live.js",))

    def next_payload(self, after: int, timeout: float) -> tuple[int, str | None]:
        """The payload after version ``after``, waiting up to ``timeout`` for one; (version, None) on a timeout."""
        with self._changed:
            if self._version <= after and not self._stop.is_set():
                self._changed.wait(timeout)
            if self._version > after and self._payload is not None:
                return self._version, self._payload
            return self._version, None

    @property
    def stopped(self) -> bool:
        return self._stop.is_set()


def _signature(folder: Path | None) -> tuple[Any, ...] | None:
    """What changes when a run writes: the folder's name and its files' sizes and modification times."""
    if folder is None:
        return None
    try:
        return (str(folder), *sorted((p.name, p.stat().st_size, p.stat().st_mtime_ns) for p in folder.iterdir()))
    except OSError:  # renamed from <out>.incomplete to <out> between the two calls
        return None


def _handler(view: LiveView) -> type[BaseHTTPRequestHandler]:
    class Handler(BaseHTTPRequestHandler):
        def do_GET(self) -> None:  # noqa: N802 - http.server's name
            if self.path in ("/", "/index.html"):
                try:
                    body = view.page().encode("utf-8")
                except ViewError as exc:
                    self.send_error(503, str(exc))
                    return
                self.send_response(200)
                self.send_header("Content-Type", "text/html; charset=utf-8")
                self.send_header("Content-Length", str(len(body)))
                self.send_header("Cache-Control", "no-store")
                self.end_headers()
                self.wfile.write(body)
            elif self.path == "/events":
                self._events()
            else:
                self.send_error(404)

        def _events(self) -> None:
            self.send_response(200)
            self.send_header("Content-Type", "text/event-stream")
            self.send_header("Cache-Control", "no-store")
            self.end_headers()
            version = 0
            try:
                while not view.stopped:
                    version, payload = view.next_payload(version, KEEPALIVE)
                    self.wfile.write(b": keep-alive\n\n" if payload is None else f"data: {payload}\n\n".encode("ascii"))
                    self.wfile.flush()
            except OSError:  # the page was closed
                return

        def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 - http.server's signature
            log.debug("live view: %s", format % args)

    return Handler
