"""What vcran's two HTTP servers (the live notification listener, the broker) need beyond ``http.server``.

Both face peers vcran does not control (Orion, FiLiP, anything on the network), so both get:

* a listen backlog that takes a burst: socketserver's default of 5 made Orion's simultaneous
  notifications wait for TCP retransmits (1 s, 3 s, ...) past Orion's 5 s notification timeout;
* deadlines per connection: a kept-alive connection with no request for ``idle_timeout`` seconds is
  closed, and a request must arrive in full and be answered within ``request_timeout`` seconds, so a
  client that sends a byte now and then (slow loris) cannot hold a thread;
* a client that goes away mid-request is not an error: no traceback on stderr;
* log lines quote peer text through :func:`one_line`, so a newline in a peer's string cannot forge log
  lines;
* :func:`drain`, to read and drop what a client still sends after an early answer (411, 413), so that it
  reads the answer instead of a connection reset.
"""

from __future__ import annotations

import logging
import socket
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

log = logging.getLogger("vcran.http")

#: Pending connections the kernel queues before accept (it caps this at net.core.somaxconn).
BACKLOG = 1024


def one_line(text: Any, limit: int = 200) -> str:
    """``text`` fit for one log line: control characters escaped, at most ``limit`` characters."""
    text = str(text)
    if not text.isprintable():
        text = text.encode("unicode_escape", "backslashreplace").decode("ascii")
    return text if len(text) <= limit else text[:limit] + "..."


def drain(connection: socket.socket, seconds: float = 2.0) -> None:
    """After an answer sent without reading the body: stop writing, then read and drop what the client
    still sends until it closes, for at most ``seconds``."""
    deadline = time.monotonic() + seconds
    try:
        connection.shutdown(socket.SHUT_WR)
        while (left := deadline - time.monotonic()) > 0:
            connection.settimeout(left)
            if not connection.recv(65536):
                break
    except OSError:
        pass


class Deadlines:
    """Shuts down connections that outlive their deadline; a blocked read then sees the end of the
    stream and the handler thread finishes. One thread per server, waking four times a second."""

    TICK = 0.25

    def __init__(self) -> None:
        self._due: dict[socket.socket, float] = {}
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="vcran-deadlines", daemon=True)
        self._thread.start()

    @contextmanager
    def armed(self, connection: socket.socket, seconds: float) -> Iterator[None]:
        with self._lock:
            self._due[connection] = time.monotonic() + seconds
        try:
            yield
        finally:
            with self._lock:
                self._due.pop(connection, None)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=1)

    def _run(self) -> None:
        while not self._stop.wait(self.TICK):
            now = time.monotonic()
            with self._lock:
                expired = [c for c, due in self._due.items() if due <= now]
                for connection in expired:
                    del self._due[connection]
            for connection in expired:
                try:
                    connection.shutdown(socket.SHUT_RDWR)
                except OSError:
                    pass


class Server(ThreadingHTTPServer):
    """A threading HTTP server with a deep backlog, deadlines and quiet disconnects (module docstring)."""

    request_queue_size = BACKLOG

    def __init__(self, address: tuple[str, int], handler: type[Handler], *, idle_timeout: float,
                 request_timeout: float) -> None:
        self.idle_timeout, self.request_timeout = idle_timeout, request_timeout
        self.deadlines = Deadlines()
        try:
            super().__init__(address, handler)
        except BaseException:
            self.deadlines.close()
            raise

    def handle_error(self, request: Any, client_address: Any) -> None:
        error = sys.exc_info()[1]
        if isinstance(error, OSError):  # the client went away, or a deadline cut it off
            log.debug("connection from %s ended: %s", client_address, error)
            return
        log.exception("unexpected error serving %s", client_address)

    def server_close(self) -> None:
        super().server_close()
        self.deadlines.close()


class Handler(BaseHTTPRequestHandler):
    """HTTP/1.1 with keep-alive, under the server's idle and request deadlines."""

    protocol_version = "HTTP/1.1"
    server: Server

    def handle_one_request(self) -> None:
        try:
            self.connection.settimeout(self.server.idle_timeout)
            # idle until the next request starts or the client closes (rfile is a BufferedReader)
            waiting = self.rfile.peek(1)  # type: ignore[attr-defined]
        except OSError:  # includes the idle timeout
            waiting = b""
        if not waiting:
            self.close_connection = True
            return
        self.connection.settimeout(self.server.request_timeout)
        with self.server.deadlines.armed(self.connection, self.server.request_timeout):
            super().handle_one_request()

    def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 - http.server's signature
        log.info("%s %s", self.address_string(), one_line(format % args))
