"""The HTTP shell around the broker engine, and :func:`start_broker` for tests and ``vcran broker``.

The shell does what the pure engine cannot: read raw headers and bodies off sockets. It reads a body
only when Content-Length announces one of at most 1 MiB; otherwise (no Content-Length, chunked, too
large) the engine answers from the headers alone (411, 413) and the shell closes the connection after
draining what the client sent, so that the client reads the answer instead of a connection reset.

One lock serialises calls into the engine; notifications are queued before the response is written,
so once a client has its response, :meth:`BrokerHandle.wait_notifications` covers what it caused.
"""

from __future__ import annotations

import logging
import random
import socket
import socketserver
import threading
import time
from collections.abc import Callable
from typing import Self

from vcran import __version__
from vcran.broker.engine import Broker
from vcran.broker.notifier import DEFAULT_TIMEOUT, Notifier
from vcran.broker.protocol import Notification, Request, Response, json_response
from vcran.core.orion_rules import MAX_REQUEST_BYTES
from vcran.io.http_server import Handler, Server, drain, one_line

log = logging.getLogger("vcran.broker")

#: An oversized body is read and thrown away up to this size; beyond it the connection is just closed.
DISCARD_LIMIT = 64 * MAX_REQUEST_BYTES
BODY_METHODS = ("POST", "PUT", "PATCH")
#: Seconds a kept-alive connection may sit without a request before the broker closes it.
IDLE_TIMEOUT = 30.0
#: Seconds for a request to arrive in full and be answered (a 1 MiB body over a slow link fits).
REQUEST_TIMEOUT = 30.0


class _BrokerServer(Server):
    daemon_threads = False  # server_close() joins handler threads: stop() leaves nothing running
    allow_reuse_address = True  # restart on the same port while old connections sit in TIME_WAIT

    def __init__(self, address: tuple[str, int], broker: Broker, notifier_timeout: float, *,
                 idle_timeout: float, request_timeout: float) -> None:
        self.broker = broker
        self.lock = threading.Lock()
        self.connections: set[socket.socket] = set()
        self.notifier = Notifier(self.record_delivery, timeout=notifier_timeout)
        try:
            super().__init__(address, _Handler, idle_timeout=idle_timeout, request_timeout=request_timeout)
        except BaseException:  # the port is taken: nothing may keep running
            self.notifier.close()
            raise

    def server_bind(self) -> None:
        # HTTPServer.server_bind looks up the host's FQDN, which can stall without DNS; skip it.
        socketserver.TCPServer.server_bind(self)
        self.server_name, self.server_port = str(self.server_address[0]), int(self.server_address[1])

    def answer(self, request: Request) -> Response:
        """Run the engine on one request, queue its notifications, return its response."""
        try:
            with self.lock:
                outcome = self.broker.handle(request)
        except Exception:  # an engine bug answers 500 and leaves the broker running
            log.exception("broker failed on %s %s", request.method, request.target)
            error = {"error": "InternalServerError", "description": "vcran broker internal error"}
            return json_response(error, 500)
        self.notifier.submit(outcome.notifications)
        return outcome.response

    def record_delivery(self, notification: Notification, status: int | None, reason: str) -> None:
        with self.lock:
            self.broker.delivery_result(notification, status, reason)

    def close_connections(self) -> None:
        with self.lock:
            connections = list(self.connections)
        for connection in connections:
            try:
                connection.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass


class _Handler(Handler):
    server: _BrokerServer

    def version_string(self) -> str:
        return f"vcran-broker/{__version__}"

    def setup(self) -> None:
        super().setup()
        # Headers and body go out in separate writes; without this, Nagle's algorithm meets the
        # client's delayed ACK and every answer waits ~40 ms.
        self.connection.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        with self.server.lock:
            self.server.connections.add(self.connection)

    def finish(self) -> None:
        with self.server.lock:
            self.server.connections.discard(self.connection)
        super().finish()

    def do_GET(self) -> None:
        self._serve()

    do_POST = do_PUT = do_PATCH = do_DELETE = do_OPTIONS = do_HEAD = do_GET

    def _serve(self) -> None:
        headers = tuple(self.headers.items())
        length_header = self.headers.get("Content-Length", "").strip()
        length = int(length_header) if length_header.isdigit() else None
        chunked = "chunked" in self.headers.get("Transfer-Encoding", "").lower()
        body = b""
        unread = chunked or (length is None and self.command in BODY_METHODS)
        if not unread and length:
            if length <= MAX_REQUEST_BYTES:
                body = self.rfile.read(length)
            else:
                unread = not self._discard(length)
        response = self.server.answer(Request(self.command, self.path, headers, body))
        self._send(response, close=unread or (length or 0) > MAX_REQUEST_BYTES)
        if unread:
            drain(self.connection)

    def _send(self, response: Response, *, close: bool) -> None:
        self.send_response(response.status)
        for name, value in response.headers:
            self.send_header(name, value)
        self.send_header("Content-Length", str(len(response.body)))
        if close:
            self.send_header("Connection", "close")
            self.close_connection = True
        self.end_headers()
        if self.command != "HEAD":
            self.wfile.write(response.body)
        self.wfile.flush()

    def _discard(self, length: int) -> bool:
        """Read and drop an oversized body without keeping it; False if it is too big even for that."""
        if length > DISCARD_LIMIT:
            return False
        remaining = length
        while remaining:
            chunk = self.rfile.read(min(remaining, 65536))
            if not chunk:
                break
            remaining -= len(chunk)
        return True

    def log_message(self, format: str, *args: object) -> None:  # noqa: A002 - http.server's signature
        log.info("%s %s", self.address_string(), one_line(format % args))


class BrokerHandle:
    """A running broker: ``url`` to send NGSI v2 requests to, ``stop()`` to end it (data is lost)."""

    def __init__(self, server: _BrokerServer, thread: threading.Thread) -> None:
        self._server = server
        self._thread = thread
        self.host, self.port = server.server_name, server.server_port
        self.url = f"http://{self.host}:{self.port}"

    @property
    def broker(self) -> Broker:
        """The engine, for inspection in tests; call it only through HTTP while the server runs."""
        return self._server.broker

    def wait_notifications(self, timeout: float = DEFAULT_TIMEOUT) -> bool:
        """Wait until every notification caused by requests answered so far has been delivered (or
        has failed) and recorded; False if ``timeout`` seconds pass first."""
        return self._server.notifier.wait_idle(timeout)

    def stop(self) -> None:
        """Stop listening, cut open connections, drop queued notifications. Idempotent."""
        if not self._thread.is_alive():
            return
        self._server.shutdown()
        self._server.close_connections()
        self._server.server_close()
        self._thread.join()
        self._server.notifier.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


def start_broker(
    host: str = "127.0.0.1",
    port: int = 0,
    *,
    clock: Callable[[], float] = time.time,
    rng: random.Random | None = None,
    notification_timeout: float = DEFAULT_TIMEOUT,
    idle_timeout: float = IDLE_TIMEOUT,
    request_timeout: float = REQUEST_TIMEOUT,
) -> BrokerHandle:
    """Start a fresh, empty broker listening on ``host:port`` (0: any free port) in background threads.

    Binding uses SO_REUSEADDR, so a broker stopped with :meth:`BrokerHandle.stop` can be replaced by a
    new one on the same port at once (the way tests simulate an Orion restart). A kept-alive connection
    idle for ``idle_timeout`` seconds is closed; a request must arrive and be answered within
    ``request_timeout`` seconds. Raises OSError when the address cannot be bound, OverflowError for a
    port outside 0..65535.
    """
    server = _BrokerServer((host, port), Broker(clock=clock, rng=rng), notification_timeout,
                           idle_timeout=idle_timeout, request_timeout=request_timeout)
    thread = threading.Thread(
        target=server.serve_forever, kwargs={"poll_interval": 0.05}, name="vcran-broker", daemon=True
    )
    thread.start()
    return BrokerHandle(server, thread)
