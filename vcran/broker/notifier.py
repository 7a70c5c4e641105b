"""Delivering notifications: HTTP POSTs in background threads, never on the request path.

Order: notifications of one subscription are delivered one at a time, in the order the engine made
them (a listener sees a robot's commands in order); different subscriptions proceed in parallel, so a
slow or dead listener delays only its own subscription. Each outcome goes back to the engine
(``on_result``), which keeps Orion's delivery record (``lastSuccess``/``lastFailure``, ``failed``).
A delivery is tried once, like Orion's default (no retries).
"""

from __future__ import annotations

import functools
import logging
import ssl
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable

import httpx

from vcran.broker.protocol import Notification
from vcran.io.http_server import one_line

log = logging.getLogger("vcran.broker")

ResultCallback = Callable[[Notification, "int | None", str], None]

#: Orion's default notification timeout (``-httpTimeout``), in seconds.
DEFAULT_TIMEOUT = 5.0
#: How long closing waits for deliveries in flight, in seconds.
CLOSE_GRACE = 0.2


@functools.cache
def _ssl_context() -> ssl.SSLContext:
    """One verifying TLS context per process: building it costs more than the rest of a broker's start."""
    return httpx.create_ssl_context()


def _failure_reason(exc: Exception) -> str:
    """libcurl's words where Orion would report them (``lastFailureReason``), else the error itself."""
    if isinstance(exc, httpx.ConnectError):
        return "Couldn't connect to server"
    if isinstance(exc, httpx.TimeoutException):
        return "Timeout was reached"
    return f"{type(exc).__name__}: {exc}"


class Notifier:
    def __init__(
        self,
        on_result: ResultCallback,
        *,
        workers: int = 4,
        timeout: float = DEFAULT_TIMEOUT,
    ) -> None:
        self._on_result = on_result
        self._client = httpx.Client(timeout=timeout, verify=_ssl_context())
        # Send exactly the headers Orion sends: no compression offer, no explicit keep-alive.
        for name in ("Accept-Encoding", "Connection"):
            del self._client.headers[name]
        self._cond = threading.Condition()
        self._queues: dict[str, deque[Notification]] = {}  # per subscription, while it has work
        self._ready: deque[str] = deque()  # subscriptions with work and no worker on them
        self._pending = 0
        self._closed = False
        self._threads = [
            threading.Thread(target=self._work, name=f"vcran-notifier-{i}", daemon=True) for i in range(workers)
        ]
        for thread in self._threads:
            thread.start()

    def submit(self, notifications: Iterable[Notification]) -> None:
        with self._cond:
            if self._closed:
                return
            for notification in notifications:
                queue = self._queues.get(notification.subscription_id)
                if queue is None:
                    self._queues[notification.subscription_id] = deque([notification])
                    self._ready.append(notification.subscription_id)
                else:
                    queue.append(notification)
                self._pending += 1
            self._cond.notify_all()

    def wait_idle(self, timeout: float | None = None) -> bool:
        """Wait until every notification submitted so far has been delivered (or has failed) and its
        outcome recorded; False if ``timeout`` seconds pass first."""
        with self._cond:
            return self._cond.wait_for(lambda: self._pending == 0 or self._closed, timeout)

    def close(self) -> None:
        """Stop: queued notifications are dropped (as a stopping Orion loses its queue). Stopping does
        not wait for a slow listener: a delivery still in flight after a short grace period finishes
        (or times out) in its daemon thread, and its outcome no longer matters."""
        with self._cond:
            self._closed = True
            self._queues.clear()
            self._ready.clear()
            self._cond.notify_all()
        deadline = time.monotonic() + CLOSE_GRACE
        for thread in self._threads:
            thread.join(timeout=max(0.0, deadline - time.monotonic()))
        self._client.close()

    def _work(self) -> None:
        while True:
            with self._cond:
                self._cond.wait_for(lambda: self._ready or self._closed)
                if self._closed:
                    return
                subscription_id = self._ready.popleft()
                notification = self._queues[subscription_id].popleft()
            self._deliver(notification)
            with self._cond:
                self._pending -= 1
                queue = self._queues.get(subscription_id)
                if queue:
                    self._ready.append(subscription_id)
                elif queue is not None:
                    del self._queues[subscription_id]
                self._cond.notify_all()

    def _deliver(self, notification: Notification) -> None:
        try:
            timeout = self._client.timeout if notification.timeout is None else httpx.Timeout(notification.timeout)
            response = self._client.post(notification.url, content=notification.body, headers=notification.headers,
                                         timeout=timeout)
            status: int | None = response.status_code
            reason = ""
        except Exception as exc:  # noqa: BLE001 - any failure is this delivery's, never the worker's
            if self._closed:  # cut off by close(): no outcome to record, and no log from a stopped broker
                return
            status, reason = None, _failure_reason(exc)
            log.warning("notification of subscription %s to %s failed: %s", notification.subscription_id,
                        one_line(notification.url), one_line(reason))  # fmt: skip
        if self._closed:  # finished after close(): its outcome no longer matters (close's docstring)
            return
        try:
            self._on_result(notification, status, reason)
        except Exception:  # a bug in bookkeeping must not stop deliveries
            log.exception("recording a notification result failed")
