"""The notification listener: where Orion POSTs subscription notifications (SPEC §7).

A threaded ``http.server`` whose handlers take one lock: notifications are handled one at a time, so the
order in which Orion sent them on a connection is the order they enter the simulation, while an idle
keep-alive connection or a stuck client cannot block others or delay shutdown. It refuses bodies over ``max_body``
(413) and malformed ones (400) without reading more than it must, answers fast, and never lets a bad
request take it down. What to do with a good notification is the ``on_notification`` callback's
business (the transport checks the subscription id and forwards the attributes).
"""

from __future__ import annotations

import json
import logging
import threading
from collections.abc import Callable
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

log = logging.getLogger("vcran.orion")

OnNotification = Callable[[str, list[dict[str, Any]]], None]


class Listener:
    """Serve ``POST path`` on ``host:port`` in a daemon thread until :meth:`stop`."""

    def __init__(self, host: str, port: int, path: str, on_notification: OnNotification,
                 max_body: int = 1_048_576) -> None:
        listener = self

        class Handler(BaseHTTPRequestHandler):
            protocol_version = "HTTP/1.1"
            timeout = 10

            def do_POST(self) -> None:  # noqa: N802 - http.server's naming
                status, problem = listener._receive(self)
                self._answer(status, problem)

            def do_GET(self) -> None:  # noqa: N802
                self._answer(405, "notifications are POSTed")

            def _answer(self, status: int, problem: str) -> None:
                body = json.dumps({"error": problem}).encode() if problem else b""
                self.send_response(status)
                self.send_header("Content-Length", str(len(body)))
                if body:
                    self.send_header("Content-Type", "application/json")
                if status >= 400:
                    self.send_header("Connection", "close")
                    self.close_connection = True
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, format: str, *args: Any) -> None:  # quiet: the transport logs what matters
                pass

        self.path = path
        self.max_body = max_body
        self._on = on_notification
        self._lock = threading.Lock()
        self._server = ThreadingHTTPServer((host, port), Handler)
        self._server.daemon_threads = True
        self._server.block_on_close = False
        self.port = self._server.server_address[1]
        self._thread = threading.Thread(target=self._server.serve_forever, name="vcran-listener", daemon=True)
        self._thread.start()

    def _receive(self, request: BaseHTTPRequestHandler) -> tuple[int, str]:
        if request.path.split("?", 1)[0] != self.path:
            return self._refuse(404, f"no listener at {request.path}")
        length = request.headers.get("Content-Length")
        if length is None or not length.isdigit():
            return self._refuse(411, "Content-Length required")
        if int(length) > self.max_body:
            return self._refuse(413, f"notification of {length} bytes is over the {self.max_body}-byte limit")
        try:
            body = json.loads(request.rfile.read(int(length)))
        except (ValueError, RecursionError):
            return self._refuse(400, "body is not JSON")
        if not isinstance(body, dict) or not isinstance(body.get("subscriptionId"), str) \
                or not isinstance(body.get("data"), list):
            return self._refuse(400, "not an NGSI v2 notification: need subscriptionId and data")
        try:
            with self._lock:
                self._on(body["subscriptionId"], [e for e in body["data"] if isinstance(e, dict)])
        except Exception:  # a bug downstream must not kill the listener
            log.exception("notification handling failed")
            return 500, "internal error"
        return 204, ""

    def _refuse(self, status: int, problem: str) -> tuple[int, str]:
        log.warning("notification refused (%s): %s", status, problem)
        return status, problem

    def stop(self) -> None:
        self._server.shutdown()
        self._server.server_close()
        self._thread.join(timeout=5)
