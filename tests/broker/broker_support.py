"""Test helpers for the broker: a real HTTP listener that records the notifications it receives, and a
raw-socket client for requests httpx will not send (no Content-Length, chunked)."""

from __future__ import annotations

import socket
import sys
import threading
from dataclasses import dataclass
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any


@dataclass(frozen=True)
class Received:
    method: str
    path: str
    headers: list[tuple[str, str]]
    body: bytes


class _Server(ThreadingHTTPServer):
    """Handler threads are joined on close, so none outlives its test; a request that fails (the
    broker hung up on a slow answer) is kept in ``errors``, not printed on whatever stderr is current
    (socketserver's default, which a later test's captured stderr would receive)."""

    daemon_threads = False
    block_on_close = True

    def __init__(self, *args: object) -> None:
        super().__init__(*args)  # type: ignore[arg-type]
        self.errors: list[BaseException] = []
        self.connections: set[socket.socket] = set()

    def process_request_thread(self, request: Any, client_address: Any) -> None:
        self.connections.add(request)
        try:
            super().process_request_thread(request, client_address)
        finally:
            self.connections.discard(request)

    def handle_error(self, request: object, client_address: object) -> None:
        self.errors.append(sys.exc_info()[1])  # type: ignore[arg-type]

    def server_close(self) -> None:
        """Ends kept-alive connections (their handlers wait for a next request that a client holding
        the connection open may never send) but lets a handler answer the request it already read."""
        for connection in list(self.connections):
            try:
                connection.shutdown(socket.SHUT_RD)
            except OSError:
                pass
        super().server_close()  # joins the handler threads


class Listener:
    """A notification listener on 127.0.0.1 that answers every request with ``status`` (once ``gate``,
    if given, is set: a slow listener). ``stop()`` returns once every request it took is answered."""

    def __init__(self, status: int = 200, gate: threading.Event | None = None) -> None:
        self.received: list[Received] = []
        self.status = status
        lock = threading.Lock()
        listener = self

        class Handler(BaseHTTPRequestHandler):
            protocol_version = "HTTP/1.1"

            def do_POST(self) -> None:
                body = self.rfile.read(int(self.headers.get("Content-Length", 0)))
                with lock:
                    listener.received.append(Received(self.command, self.path, list(self.headers.items()), body))
                if gate is not None:
                    gate.wait(10)
                self.send_response(listener.status)
                self.send_header("Content-Length", "0")
                self.end_headers()

            def log_message(self, *args: object) -> None:
                pass

        self._server = _Server(("127.0.0.1", 0), Handler)
        self.port = self._server.server_address[1]
        self.url = f"http://127.0.0.1:{self.port}/notify"
        self._thread = threading.Thread(target=self._server.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
        self._thread.start()

    def take(self) -> list[Received]:
        """The notifications received since the last call."""
        taken, self.received = self.received, []
        return taken

    def stop(self) -> None:
        self._server.shutdown()
        self._server.server_close()


@dataclass(frozen=True)
class RawResponse:
    status: int
    headers: dict[str, str]  # lower-cased names
    body: bytes


def raw_request(port: int, head: str, body: bytes = b"") -> RawResponse:
    """Send ``head`` (request line and headers, CRLF-separated, without the blank line) and ``body`` as
    they are, then read the answer until the server closes the connection."""
    with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
        sock.sendall(head.encode() + b"\r\n\r\n" + body)
        data = b""
        while chunk := sock.recv(65536):
            data += chunk
    raw_head, _, payload = data.partition(b"\r\n\r\n")
    status_line, *header_lines = raw_head.decode().split("\r\n")
    headers = {}
    for line in header_lines:
        name, _, value = line.partition(":")
        headers[name.strip().lower()] = value.strip()
    return RawResponse(int(status_line.split()[1]), headers, payload)
