"""The notification listener: where Orion POSTs subscription notifications (docs/contract.md §7).

A threaded ``http.server`` (:class:`vcran.io.http_server.Server`: deep listen backlog, idle and request
deadlines, quiet disconnects) whose handlers take one lock: notifications are handled one at a time, so
the order in which Orion sent them on a connection is the order they enter the simulation, while an
idle keep-alive connection or a slow client cannot block others or delay shutdown. It answers 415 to a
body that is not ``application/json``, 411 without a Content-Length, 413 over ``max_body`` (reading and
dropping what the client still sends, so that it sees the answer), 400 to a malformed notification, and
never lets a bad request take it down. What to do with a good notification is the ``on_notification``
callback's business (the transport checks the subscription id and forwards the attributes).
"""

from __future__ import annotations

import json
import logging
import threading
from collections.abc import Callable
from typing import Any

from vcran.io.http_server import Handler, Server, drain, one_line

log = logging.getLogger("vcran.orion")

OnNotification = Callable[[str, list[dict[str, Any]]], None]

#: Seconds a kept-alive connection may sit without a request (Orion reconnects when it needs to).
IDLE_TIMEOUT = 30.0
#: Seconds for a notification to arrive in full and be answered; Orion itself gives up after 5.
REQUEST_TIMEOUT = 10.0


class Listener:
    """Serve ``POST path`` on ``host:port`` in a daemon thread until :meth:`stop`."""

    def __init__(self, host: str, port: int, path: str, on_notification: OnNotification,
                 max_body: int = 1_048_576, *, idle_timeout: float = IDLE_TIMEOUT,
                 request_timeout: float = REQUEST_TIMEOUT) -> None:
        listener = self

        class NotificationHandler(Handler):
            def do_POST(self) -> None:  # noqa: N802 - http.server's naming
                status, problem = listener._receive(self)
                self._answer(status, problem)
                if status in (411, 413):  # the body was not read
                    drain(self.connection)

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

            def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 - the transport logs what matters
                pass

        self.path = path
        self.max_body = max_body
        self._on = on_notification
        self._lock = threading.Lock()
        self._server = Server((host, port), NotificationHandler, idle_timeout=idle_timeout,
                              request_timeout=request_timeout)
        self._server.daemon_threads = True
        self._server.block_on_close = False
        self.port = self._server.server_address[1]
        self._thread = threading.Thread(target=self._server.serve_forever, name="vcran-listener", daemon=True)
        self._thread.start()

    def _receive(self, request: Handler) -> tuple[int, str]:
        if request.path.split("?", 1)[0] != self.path:
            return self._refuse(404, f"no listener at {one_line(request.path)}")
        media = request.headers.get("Content-Type", "").split(";", 1)[0].strip().lower()
        if media != "application/json":
            return self._refuse(415, f"Content-Type {one_line(media or 'missing', 60)}: notifications are application/json")
        length = request.headers.get("Content-Length", "").strip()
        if not length.isdigit():
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
