"""The broker's inputs and outputs as plain values: requests in, responses and notifications out.

The engine (:mod:`vcran.broker.engine`) never touches a socket, in the manner of h11: a caller hands it a
:class:`Request` and gets back an :class:`Outcome`, the :class:`Response` to send plus the
:class:`Notification` s to POST to subscribers. Bodies are bytes rendered exactly as Orion renders them
(compact JSON, UTF-8), so that a notification's Content-Length matches the one Orion would send.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from vcran.broker.jsontext import parse_json, render_json

Headers = tuple[tuple[str, str], ...]

JSON_CONTENT_TYPE = "application/json"


def header_value(headers: Headers, name: str) -> str | None:
    """The first value of header ``name`` (case-insensitive), or None."""
    lowered = name.lower()
    for key, value in headers:
        if key.lower() == lowered:
            return value
    return None


def media_type(value: str | None) -> str | None:
    """The media type of an Accept item, without parameters (``;q=...``), lower-cased."""
    return value.split(";", 1)[0].strip().lower() if value else None


def body_media_type(value: str | None) -> str | None:
    """A Content-Type as Orion compares it (rest/rest.cpp httpHeaderGet): cut at the first ``;``, and
    otherwise as sent, so ``Application/JSON`` or ``application/json ;charset=utf-8`` is not JSON."""
    return value.split(";", 1)[0] if value else None


def accepted_media(request: Request) -> list[str]:
    """The media ranges of the request's Accept header; no header accepts anything (``*/*``)."""
    header = request.header("Accept")
    if header is None or not header.strip():
        return ["*/*"]
    return [m for m in (media_type(item) for item in header.split(",")) if m]


@dataclass(frozen=True, slots=True)
class Request:
    """One HTTP request as received: ``target`` is the path with its query string, still %-encoded.

    ``headers`` are the raw header lines; the engine reads Content-Length and Content-Type from them
    (not from ``body``) because Orion answers 411/413/415 from the headers alone.
    """

    method: str
    target: str
    headers: Headers = ()
    body: bytes = b""

    def header(self, name: str) -> str | None:
        return header_value(self.headers, name)

    @classmethod
    def make(
        cls,
        method: str,
        target: str,
        body: Any = None,
        headers: Mapping[str, str] | None = None,
    ) -> Request:
        """A well-formed request, as an HTTP client would send it: a JSON body (if any) with its
        Content-Type and Content-Length; ``body`` given as bytes is sent as is."""
        all_headers = dict(headers or {})
        raw = b""
        if body is not None:
            raw = body if isinstance(body, bytes) else render_json(body)
            all_headers.setdefault("Content-Type", JSON_CONTENT_TYPE)
            all_headers.setdefault("Content-Length", str(len(raw)))
        return cls(method, target, tuple(all_headers.items()), raw)


@dataclass(frozen=True, slots=True)
class Response:
    status: int
    headers: Headers = ()
    body: bytes = b""

    def header(self, name: str) -> str | None:
        return header_value(self.headers, name)

    def json(self) -> Any:
        return parse_json(self.body) if self.body else None


@dataclass(frozen=True, slots=True)
class Notification:
    """One HTTP POST that a subscription asks for: the subscription's ``url``, headers and body;
    ``timeout`` in seconds when the subscription set its own (``http.timeout``), else None."""

    subscription_id: str
    tenant: str
    url: str
    headers: Headers
    body: bytes
    timeout: float | None = None

    def header(self, name: str) -> str | None:
        return header_value(self.headers, name)

    def json(self) -> Any:
        return parse_json(self.body)


@dataclass(frozen=True, slots=True)
class Outcome:
    """What :meth:`Broker.handle` returns: the response and the notifications to send, in order."""

    response: Response
    notifications: tuple[Notification, ...] = ()


def json_response(value: Any, status: int = 200, headers: Headers = ()) -> Response:
    return Response(status, (("Content-Type", JSON_CONTENT_TYPE), *headers), render_json(value))


def empty_response(status: int = 204, headers: Headers = ()) -> Response:
    return Response(status, headers)


class NgsiError(Exception):
    """An NGSI v2 error answer: HTTP status, Orion's ``error`` name and its ``description``.

    Raised anywhere inside the engine; :meth:`Broker.handle` turns it into the response.
    """

    def __init__(self, status: int, error: str, description: str, headers: Headers = ()) -> None:
        super().__init__(f"{status} {error}: {description}")
        self.status = status
        self.error = error
        self.description = description
        self.headers = headers

    def response(self) -> Response:
        return json_response({"error": self.error, "description": self.description}, self.status, self.headers)


def bad_request(description: str) -> NgsiError:
    return NgsiError(400, "BadRequest", description)


def not_found(description: str) -> NgsiError:
    return NgsiError(404, "NotFound", description)


def unprocessable(description: str) -> NgsiError:
    return NgsiError(422, "Unprocessable", description)


def not_implemented(what: str) -> NgsiError:
    """For NGSI v2 features Orion has and this broker lacks: say so rather than answer wrongly."""
    return NgsiError(501, "NotImplemented", f"vcran broker does not implement {what}")


ENTITY_NOT_FOUND = "The requested entity has not been found. Check type and id"
ATTRIBUTE_NOT_FOUND = "The entity does not have such an attribute"
SUBSCRIPTION_NOT_FOUND = "The requested subscription has not been found. Check id"


def parse_error() -> NgsiError:
    return NgsiError(400, "ParseError", "Errors found in incoming JSON buffer")
