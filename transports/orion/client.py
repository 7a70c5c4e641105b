"""A small NGSI v2 client for what vcran needs of Orion, over httpx.

Every foreign exception is translated here, at the boundary, into :class:`OrionError`: callers see
:class:`OrionUnavailable` when Orion cannot answer properly (connection refused or reset, timeout, 5xx,
a body that is not the JSON it should be) and :class:`OrionRejected` when it answered "no" (4xx, with
Orion's ``error`` and ``description``). The access token is sent as a header and never appears in an
error message, a log line or a repr.
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterable
from dataclasses import dataclass
from datetime import UTC
from email.utils import parsedate_to_datetime
from typing import Any

import httpx

#: Orion's largest page of entities.
PAGE = 1000
#: Keep the id list of one GET well under common URL limits; more ids go in further requests.
MAX_QUERY_IDS_CHARS = 6000


class OrionError(Exception):
    """Base of the client's errors. ``retry_after``: the seconds Orion (or a proxy in front of it) asked
    the client to wait, from a ``Retry-After`` header on a 429 or 503; None when it did not say."""

    retry_after: float | None = None


class OrionUnavailable(OrionError):
    """Orion could not give a proper answer: unreachable, too slow, 5xx or a malformed body."""


class OrionRejected(OrionError):
    """Orion refused the request (4xx)."""

    def __init__(self, status: int, error: str, description: str, what: str) -> None:
        super().__init__(f"{what}: {status} {error}: {description}")
        self.status, self.error, self.description = status, error, description


@dataclass(frozen=True)
class Tenant:
    """``Fiware-Service`` and ``Fiware-ServicePath`` (optional) and the access token (secret)."""

    service: str | None = None
    service_path: str | None = None
    token: str | None = None

    def headers(self) -> dict[str, str]:
        h = {}
        if self.service:
            h["Fiware-Service"] = self.service
        if self.service_path:
            h["Fiware-ServicePath"] = self.service_path
        if self.token:
            h["X-Auth-Token"] = self.token
        return h

    def __repr__(self) -> str:  # the token stays out of reprs, logs and tracebacks
        return f"Tenant(service={self.service!r}, service_path={self.service_path!r}, token={'***' if self.token else None})"


class OrionClient:
    def __init__(self, url: str, tenant: Tenant = Tenant(), *, timeout: float = 5.0,
                 transport: httpx.BaseTransport | None = None) -> None:
        self.url = url.rstrip("/")
        self._http = httpx.Client(
            base_url=self.url, headers=tenant.headers(), timeout=httpx.Timeout(timeout, connect=min(timeout, 2.0)),
            transport=transport,
        )

    def close(self) -> None:
        self._http.close()

    # --- entities ---------------------------------------------------------------------------------------

    def entities(self, entity_type: str, ids: list[str], attrs: Iterable[str]) -> list[dict[str, Any]]:
        """Normalized entities of ``ids`` with ``attrs`` (missing entities are simply absent)."""
        out: list[dict[str, Any]] = []
        attr_list = ",".join(attrs)
        for chunk in _id_chunks(ids):
            offset = 0
            while True:
                params = {"type": entity_type, "id": ",".join(chunk), "attrs": attr_list,
                          "limit": str(PAGE), "offset": str(offset)}
                page = self._json("GET", "/v2/entities", "read entities", params=params)
                if not isinstance(page, list):
                    raise OrionUnavailable(f"read entities: expected a JSON array, got {type(page).__name__}")
                out.extend(e for e in page if isinstance(e, dict))
                if len(page) < PAGE:
                    break
                offset += PAGE
        return out

    def update(self, body: bytes, *, forced: bool = False) -> None:
        """``POST /v2/op/update`` with a ready body (``vcran.core.opil.codec.split_batch``); ``forced`` adds
        ``options=forcedUpdate``: Orion then notifies every attribute of the body, changed or not."""
        params = {"options": "forcedUpdate"} if forced else None
        self._call("POST", "/v2/op/update", "batch update", content=body, params=params)

    def append_attrs(self, entity_id: str, entity_type: str, attrs: dict[str, Any]) -> None:
        """``POST /v2/entities/{id}/attrs``: create or update attributes of an existing entity."""
        self._call("POST", f"/v2/entities/{entity_id}/attrs", f"update {entity_id}",
                   params={"type": entity_type}, content=_json_bytes(attrs))

    def delete_entity(self, entity_id: str, entity_type: str) -> bool:
        """Delete an entity; False when it did not exist."""
        try:
            self._call("DELETE", f"/v2/entities/{entity_id}", f"delete {entity_id}", params={"type": entity_type})
        except OrionRejected as exc:
            if exc.status == 404:
                return False
            raise
        return True

    # --- subscriptions ----------------------------------------------------------------------------------

    def subscribe(self, subscription: dict[str, Any]) -> str:
        """Create a subscription; returns its id (from the ``Location`` header)."""
        response = self._call("POST", "/v2/subscriptions", "create subscription", content=_json_bytes(subscription))
        location = response.headers.get("Location", "")
        sid = location.rsplit("/", 1)[-1]
        if not location.startswith("/v2/subscriptions/") or not sid:
            raise OrionUnavailable(f"create subscription: no subscription id in Location {location!r}")
        return sid

    def subscription(self, sid: str) -> dict[str, Any] | None:
        """The subscription as Orion shows it (with its delivery record), or None when Orion has no
        such subscription."""
        try:
            found = self._json("GET", f"/v2/subscriptions/{sid}", "read subscription")
        except OrionRejected as exc:
            if exc.status == 404:
                return None
            raise
        if not isinstance(found, dict):
            raise OrionUnavailable(f"read subscription: expected a JSON object, got {type(found).__name__}")
        return found

    def unsubscribe(self, sid: str) -> None:
        try:
            self._call("DELETE", f"/v2/subscriptions/{sid}", "delete subscription")
        except OrionRejected as exc:
            if exc.status != 404:
                raise

    # --- plumbing ---------------------------------------------------------------------------------------

    def _json(self, method: str, path: str, what: str, **kw: Any) -> Any:
        response = self._call(method, path, what, **kw)
        try:
            return response.json()
        except ValueError:
            raise OrionUnavailable(f"{what}: the answer is not JSON") from None

    def _call(self, method: str, path: str, what: str, *, content: bytes | None = None, **kw: Any) -> httpx.Response:
        headers = {"Content-Type": "application/json"} if content is not None else None
        try:
            response = self._http.request(method, path, content=content, headers=headers, **kw)
        except httpx.TimeoutException as exc:
            raise OrionUnavailable(f"{what}: Orion at {self.url} did not answer in time") from exc
        except httpx.HTTPError as exc:
            raise OrionUnavailable(f"{what}: Orion at {self.url} is unreachable ({type(exc).__name__})") from exc
        if response.status_code >= 400:
            failure: OrionError
            if response.status_code >= 500:
                failure = OrionUnavailable(f"{what}: Orion answered {response.status_code}")
            else:
                failure = OrionRejected(response.status_code, *_error_body(response), what)
            failure.retry_after = retry_after(response.headers.get("Retry-After"))
            raise failure
        return response


def retry_after(value: str | None, now: float | None = None) -> float | None:
    """Seconds from a ``Retry-After`` header: delta-seconds or an HTTP date (RFC 9110 §10.2.3); None
    when absent or unreadable (a malformed header must not stop the sender, it only loses the hint)."""
    if not value:
        return None
    value = value.strip()
    if value.isdigit():
        return float(value)
    try:
        when = parsedate_to_datetime(value)
    except (TypeError, ValueError, IndexError):
        return None
    if when.tzinfo is None:  # an HTTP date is GMT; a naive result means the header said "-0000"
        when = when.replace(tzinfo=UTC)
    return max(0.0, when.timestamp() - (time.time() if now is None else now))


def _error_body(response: httpx.Response) -> tuple[str, str]:
    try:
        body = response.json()
        return str(body.get("error", "")), str(body.get("description", ""))
    except (ValueError, AttributeError):
        return "", response.text[:200]


def _json_bytes(value: Any) -> bytes:
    return json.dumps(value, separators=(",", ":"), allow_nan=False).encode()


def _id_chunks(ids: list[str]) -> list[list[str]]:
    chunks: list[list[str]] = [[]]
    size = 0
    for i in ids:
        if chunks[-1] and size + len(i) + 1 > MAX_QUERY_IDS_CHARS:
            chunks.append([])
            size = 0
        chunks[-1].append(i)
        size += len(i) + 1
    return chunks if chunks[0] else []
