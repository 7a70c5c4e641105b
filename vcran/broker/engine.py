"""The broker engine: a pure object that turns one HTTP request into a response and notifications.

It owns all broker state (tenants of entities and subscriptions) but no socket, thread or wall clock:
the time it stamps on subscriptions comes from the injected ``clock``, the ids it makes from the injected
``rng``. :mod:`vcran.broker.server` is the thin HTTP shell around it, :mod:`vcran.broker.notifier` the
part that POSTs the notifications. Not thread-safe: the shell serialises calls.

:meth:`Broker.handle` checks a request in the order Orion does (rest.cpp, RestService.cpp), because
when a request is wrong in two ways the client sees the first error: payload size (413), service path,
Content-Type (415), missing Content-Length (411), unknown path (400) or method (405), Accept (406),
URI parameters, JSON, tenant; then the resource's own checks.
"""

from __future__ import annotations

import random
import time
import uuid
from collections.abc import Callable
from typing import Any
from urllib.parse import parse_qsl, unquote, urlsplit

from vcran.broker import batch, entities
from vcran.broker.context import Context, Tenant
from vcran.broker.protocol import (
    SUBSCRIPTION_NOT_FOUND,
    NgsiError,
    Notification,
    Outcome,
    Request,
    Response,
    accepted_media,
    bad_request,
    body_media_type,
    empty_response,
    json_response,
    not_found,
    not_implemented,
    parse_error,
    parse_json,
)
from vcran.broker.scope import EVERYTHING, Scope
from vcran.broker.subscriptions import Subscription, parse_subscription
from vcran.core.orion_rules import FORBIDDEN_CHARS, MAX_REQUEST_BYTES, has_forbidden_chars

#: The Orion release whose answers this broker reproduces (tests/data/orion-4.7-exchanges.jsonl).
ORION_VERSION = "4.7.0"

#: URI ``options`` values Orion 4.7 accepts (``validOptions`` in its rest/ConnectionInfo.cpp). Those
#: that select nothing here are accepted and change nothing: ``normalized`` (the default), ``flowControl``,
#: ``skipInitialNotification`` (this broker sends no initial notifications, nor does Orion since 3.2),
#: ``noAttrDetail``, ``skipForwarding`` (no context providers), ``fullCounters``, ``libVersions``.
KNOWN_OPTIONS = frozenset(
    {
        "count", "normalized", "values", "keyValues", "append", "unique", "dateCreated", "dateModified",
        "noAttrDetail", "upsert", "forcedUpdate", "overrideMetadata", "flowControl", "skipForwarding",
        "fullCounters", "libVersions", "skipInitialNotification",
    }
)  # fmt: skip
#: Pairs of options Orion refuses together.
EXCLUSIVE_OPTIONS = (("keyValues", "values"), ("keyValues", "unique"), ("unique", "values"))
#: URI parameters whose values may hold forbidden characters (query languages and patterns).
FREE_TEXT_PARAMS = frozenset({"q", "mq", "idPattern", "typePattern", "georel", "geometry", "coords"})
#: Orion query features this broker does not implement: answered 501 rather than ignored.
UNSUPPORTED_PARAMS = frozenset({"q", "mq", "georel", "geometry", "coords", "orderBy", "metadata"})
#: Parameters whose repeats add up: Orion's uriArgumentGet (rest/rest.cpp) appends each ``type`` to
#: uriParamTypes, and ConnectionInfo.cpp's uriParamOptionsParse sets each ``options`` in one map. Any other
#: repeated parameter keeps its last value.
ADDING_PARAMS = frozenset({"options", "type"})

Handler = Callable[..., Response]


class Broker:
    """An in-memory NGSI v2 context broker that answers like Orion 4.7 (see docs/broker.md)."""

    def __init__(self, *, clock: Callable[[], float] = time.time, rng: random.Random | None = None) -> None:
        self._clock = clock
        self._rng = rng if rng is not None else random.Random()
        self._started = clock()
        self._tenants: dict[str, Tenant] = {}
        self._routes: dict[tuple[str, ...], dict[str, Handler]] = {
            ("version",): {"GET": self._version},
            ("v2",): {"GET": _entry_point},
            ("v2", "entities"): {"GET": entities.list_entities, "POST": entities.create_entity},
            ("v2", "entities", "*"): {"GET": entities.get_entity, "DELETE": entities.delete_entity},
            ("v2", "entities", "*", "attrs"): {
                "GET": entities.get_attrs,
                "POST": entities.post_attrs,
                "PATCH": entities.patch_attrs,
                "PUT": entities.put_attrs,
            },
            ("v2", "entities", "*", "attrs", "*"): {
                "GET": entities.get_attr,
                "PUT": entities.put_attr,
                "DELETE": entities.delete_attr,
            },
            ("v2", "entities", "*", "attrs", "*", "value"): {
                "GET": entities.get_value,
                "PUT": entities.put_value,
            },
            ("v2", "subscriptions"): {"GET": self._list_subscriptions, "POST": self._create_subscription},
            ("v2", "subscriptions", "*"): {
                "GET": self._get_subscription,
                "PATCH": self._patch_subscription,
                "DELETE": self._delete_subscription,
            },
            ("v2", "op", "update"): {"POST": batch.op_update},
            ("v2", "op", "query"): {"POST": batch.op_query},
            ("v2", "op", "notify"): {"POST": _unimplemented("POST /v2/op/notify")},
            ("v2", "types"): {"GET": _unimplemented("entity types")},
            ("v2", "types", "*"): {"GET": _unimplemented("entity types")},
            ("v2", "registrations"): dict.fromkeys(("GET", "POST"), _unimplemented("registrations")),
            ("v2", "registrations", "*"): dict.fromkeys(("GET", "PATCH", "DELETE"), _unimplemented("registrations")),
        }

    # --- the request boundary ---

    def handle(self, request: Request) -> Outcome:
        """Answer one request. Notifications are returned even when the answer is an error: a
        partial update notifies for the part it applied."""
        correlator = request.header("Fiware-Correlator") or str(uuid.UUID(int=self._rng.getrandbits(128), version=4))
        ctx: Context | None = None
        try:
            ctx, handler, args = self._check(request, correlator)
            response = handler(ctx, *args)
        except NgsiError as error:
            response = error.response()
        response = Response(response.status, (*response.headers, ("Fiware-Correlator", correlator)), response.body)
        return Outcome(response, tuple(ctx.notifications) if ctx is not None else ())

    def delivery_result(self, notification: Notification, status_code: int | None, reason: str = "") -> None:
        """Record how delivering ``notification`` went: the HTTP status the listener answered, or
        None and a reason when it could not be reached (the subscription then shows ``failed``)."""
        tenant = self._tenants.get(notification.tenant)
        subscription = tenant.subscriptions.get(notification.subscription_id) if tenant else None
        if subscription is not None:
            subscription.delivered(self._clock(), status_code, reason)

    # --- checks, in Orion's order ---

    def _check(self, request: Request, correlator: str) -> tuple[Context, Handler, tuple[str, ...]]:
        length = _content_length(request)
        if length is not None and length > MAX_REQUEST_BYTES:
            raise NgsiError(
                413,
                "RequestEntityTooLarge",
                f"payload size: {length}, max size supported: {MAX_REQUEST_BYTES}",
            )
        target = urlsplit(request.target)
        path = unquote(target.path)
        if not FORBIDDEN_CHARS.isdisjoint(path):
            raise bad_request("invalid character in URI")
        scope = Scope.of(request)
        route, args = self._resolve(path)
        takes_text = route == ("v2", "entities", "*", "attrs", "*", "value") and request.method == "PUT"
        content_type = body_media_type(request.header("Content-Type"))
        if length:
            _check_content_type(content_type, takes_text)
        if request.method in ("POST", "PUT", "PATCH") and not length:
            raise NgsiError(411, "ContentLengthRequired", "Zero/No Content-Length in PUT/POST/PATCH request")
        if route is None:
            raise bad_request("Service not found. Check your URL as probably it is wrong.")
        handler = self._routes[route].get(request.method)
        if handler is None:
            allow = ", ".join(self._routes[route])
            raise NgsiError(405, "MethodNotAllowed", "method not allowed", (("Allow", allow),))
        _check_accept(request, route[-1] == "value")
        if content_type is not None and not length and request.method in ("GET", "DELETE"):
            raise bad_request(
                "Orion accepts no payload for GET/DELETE requests. HTTP header Content-Type is thus forbidden"
            )
        params, repeated = _params(target.query)
        options = _options(repeated["options"]) if "options" in repeated else frozenset()
        body: Any = None
        text: str | None = None
        if length and request.method in ("POST", "PUT", "PATCH"):
            if content_type == "text/plain":
                text = request.body.decode("utf-8", errors="replace")
            else:
                try:
                    body = parse_json(request.body)
                except (ValueError, RecursionError):  # RecursionError: nesting deeper than Python's stack
                    raise parse_error() from None
        scope.check_tenant()
        ctx = Context(request, scope, params, options, body, correlator, self._tenants, self._clock, text,
                      repeated=repeated)
        return ctx, handler, args

    def _resolve(self, path: str) -> tuple[tuple[str, ...] | None, tuple[str, ...]]:
        """The route a path names and the ids in it; Orion ignores one trailing slash."""
        if path.endswith("/") and len(path) > 1:
            path = path[:-1]
        parts = path.split("/")[1:]
        for pattern in self._routes:
            if len(pattern) == len(parts) and all(p in ("*", part) for p, part in zip(pattern, parts)):
                args = tuple(part for p, part in zip(pattern, parts) if p == "*")
                if pattern[1:3] == ("entities", "*") and "" in args:
                    kind = "entity id" if args[0] == "" else "attribute name"
                    raise bad_request(f"{kind} length: 0, min length supported: 1")
                return pattern, args
        return None, ()

    # --- /version and subscriptions ---

    def _version(self, ctx: Context) -> Response:
        uptime = int(self._clock() - self._started)
        days, rest = divmod(uptime, 86400)
        hours, rest = divmod(rest, 3600)
        minutes, seconds = divmod(rest, 60)
        return json_response(
            {
                "orion": {
                    "version": ORION_VERSION,
                    "uptime": f"{days} d, {hours} h, {minutes} m, {seconds} s",
                    "git_hash": "c678400babb0b3e680e24b81122017884fed8bbd",
                    "compile_time": "nodate",
                    "compiled_by": "root",
                    "compiled_in": "vm",
                    "release_date": "nodate",
                    "machine": "x86_64",
                    "doc": "https://fiware-orion.rtfd.io/",
                }
            }
        )

    def _new_subscription_id(self) -> str:
        """24 hex digits like Orion's (MongoDB ObjectId) ids, unique across tenants."""
        taken = {sid for tenant in self._tenants.values() for sid in tenant.subscriptions}
        while True:
            candidate = f"{self._rng.getrandbits(96):024x}"
            if candidate not in taken:
                return candidate

    def _create_subscription(self, ctx: Context) -> Response:
        fields = parse_subscription(ctx.body)
        subscription = Subscription(
            id=self._new_subscription_id(), service_path=ctx.scope.subscription_path(), **fields
        )
        ctx.tenant(create=True).subscriptions[subscription.id] = subscription
        return empty_response(201, (("Location", f"/v2/subscriptions/{subscription.id}"),))

    def _list_subscriptions(self, ctx: Context) -> Response:
        """The tenant's subscriptions; with a Fiware-ServicePath other than ``/#``, only those created
        with exactly its first path (mongoGetSubscriptions.cpp mongoListSubscriptions)."""
        limit, offset = ctx.page_bounds()
        path = ctx.scope.subscription_filter()
        subscriptions = [
            s for s in ctx.tenant().subscriptions.values() if path in (None, EVERYTHING) or s.service_path == path
        ]
        now = self._clock()
        body = [s.render(now) for s in subscriptions[offset : offset + limit]]
        headers = (("Fiware-Total-Count", str(len(subscriptions))),) if "count" in ctx.options else ()
        return json_response(body, headers=headers)

    def _subscription(self, ctx: Context, subscription_id: str) -> Subscription:
        subscription = ctx.tenant().subscriptions.get(subscription_id)
        if subscription is None:
            raise not_found(SUBSCRIPTION_NOT_FOUND)
        return subscription

    def _get_subscription(self, ctx: Context, subscription_id: str) -> Response:
        """With a Fiware-ServicePath, found only in exactly its first path (mongoGetSubscription;
        functional test 3945_servicepath_ignored_in_get_subs, step 05)."""
        subscription = self._subscription(ctx, subscription_id)
        path = ctx.scope.subscription_filter()
        if path is not None and subscription.service_path != path:
            raise not_found(SUBSCRIPTION_NOT_FOUND)
        return json_response(subscription.render(self._clock()))

    def _patch_subscription(self, ctx: Context, subscription_id: str) -> Response:
        """Orion's mongoUpdateSubscription sets the subscription's service path to the PATCH's own
        (``/#`` without the header), whatever else the PATCH changes."""
        subscription = self._subscription(ctx, subscription_id)
        fields = parse_subscription(ctx.body, update=True)
        subscription.service_path = ctx.scope.subscription_path()
        for name, value in fields.items():
            setattr(subscription, name, value)
        return empty_response()

    def _delete_subscription(self, ctx: Context, subscription_id: str) -> Response:
        del ctx.tenant().subscriptions[self._subscription(ctx, subscription_id).id]
        return empty_response()


def _entry_point(ctx: Context) -> Response:
    return json_response(
        {
            "entities_url": "/v2/entities",
            "types_url": "/v2/types",
            "subscriptions_url": "/v2/subscriptions",
            "registrations_url": "/v2/registrations",
        }
    )


def _unimplemented(what: str) -> Handler:
    def handler(ctx: Context, *args: str) -> Response:
        raise not_implemented(what)

    return handler


def _content_length(request: Request) -> int | None:
    raw = request.header("Content-Length")
    return int(raw) if raw is not None and raw.strip().isdigit() else None


def _check_content_type(content_type: str | None, takes_text: bool) -> None:
    if content_type is None:
        raise NgsiError(
            415,
            "UnsupportedMediaType",
            "Content-Type header not used, default application/octet-stream is not supported",
        )
    if content_type != "application/json" and not (takes_text and content_type == "text/plain"):
        raise NgsiError(415, "UnsupportedMediaType", f"not supported content type: {content_type}")


def _check_accept(request: Request, text_too: bool) -> None:
    acceptable = {"*/*", "application/*", "application/json"}
    if text_too:
        acceptable |= {"text/*", "text/plain"}
    if acceptable.isdisjoint(accepted_media(request)):
        types = "application/json, text/plain" if text_too else "application/json"
        raise NgsiError(406, "NotAcceptable", f"acceptable MIME types: {types}")


def _params(query: str) -> tuple[dict[str, str], dict[str, list[str]]]:
    """The query's parameters, each with its last value, and every value of those of :data:`ADDING_PARAMS`."""
    params: dict[str, str] = {}
    repeated: dict[str, list[str]] = {}
    for key, value in parse_qsl(query, keep_blank_values=True):
        if not value:
            raise bad_request(f"Empty right-hand-side for URI param /{key}/")
        if key not in FREE_TEXT_PARAMS and (has_forbidden_chars(key) or has_forbidden_chars(value)):
            raise bad_request("invalid character in URI parameter")
        if key in UNSUPPORTED_PARAMS:
            raise not_implemented(f"the URI parameter {key!r}")
        params[key] = value
        if key in ADDING_PARAMS:
            repeated.setdefault(key, []).append(value)
    return params, repeated


def _options(values: list[str]) -> frozenset[str]:
    """The ``options`` lists as Orion splits them: leading commas skipped, any other empty item invalid;
    a repeated ``options`` adds up (:data:`ADDING_PARAMS`)."""
    options = frozenset(item for value in values for item in value.lstrip(",").split(","))
    if not options <= KNOWN_OPTIONS or any(a in options and b in options for a, b in EXCLUSIVE_OPTIONS):
        raise bad_request("Invalid value for URI param /options/")
    return options
