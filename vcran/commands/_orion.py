"""Connection options shared by the commands that talk to Orion (live, manage, send, orion)."""

from __future__ import annotations

import argparse
import logging
import os
import re
import sys
from pathlib import Path
from urllib.parse import SplitResult, urlsplit

from vcran.commands import CommandError, check_positive

TOKEN_ENV = "VCRAN_ORION_TOKEN"
#: Where ``vcran live`` and ``vcran manage`` bind their notification listener, and how often (simulated seconds) they
#: poll Orion, unless told otherwise (``--listen``, ``--poll-interval``).
LISTEN, POLL_INTERVAL = "127.0.0.1", 0.25


def check_inbound(args: argparse.Namespace) -> None:
    """How ``vcran live --orion`` and ``vcran manage --orion`` hear of Orion's changes: the notification URL (and
    where its listener binds), or the polling period, each option where it means something: a flag that would do
    nothing is a mistake (exit 2)."""
    if args.notify_url is not None:
        check_notify_url(args.notify_url)
        if args.poll_interval is not None:
            raise CommandError("--poll-interval is the polling period: without --notify-url only")
    elif args.listen is not None:
        raise CommandError("--listen is where the notification listener binds: it needs --notify-url")
    elif args.poll_interval is not None:
        check_positive("--poll-interval", args.poll_interval)


def add_connection_arguments(parser: argparse.ArgumentParser, group: argparse._MutuallyExclusiveGroup | None = None) -> None:
    """``--orion`` (required, or one of ``group``'s choices: ``vcran live --orion | --mqtt``) and Orion's tenant."""
    if group is None:
        parser.add_argument("--orion", required=True, metavar="URL", help="Orion's base URL, e.g. http://127.0.0.1:1026")
    else:
        group.add_argument("--orion", metavar="URL", help="Orion's base URL of an OPIL scenario, e.g. http://127.0.0.1:1026")
    what = "" if group is None else "--orion: "
    parser.add_argument("--service", metavar="NAME", help=f"{what}Fiware-Service (tenant)")
    parser.add_argument("--service-path", metavar="PATH", help=f"{what}Fiware-ServicePath, e.g. /factory")
    parser.add_argument("--token-file", type=Path, metavar="FILE",
                        help=f"{what}file holding the X-Auth-Token (or set {TOKEN_ENV}); never given on the command line")


def add_inbound_arguments(parser: argparse.ArgumentParser, notify_help: str) -> None:
    """How an OPIL edge hears Orion (``--notify-url``, ``--listen``, ``--poll-interval``), as :func:`check_inbound`
    checks them for ``vcran live --orion`` and ``vcran manage --orion`` alike; ``notify_help`` says who is notified."""
    parser.add_argument("--notify-url", metavar="URL", help=f"--orion: {notify_help}")
    parser.add_argument("--listen", metavar="HOST",
                        help=f"--orion: address the notification listener binds to (default {LISTEN}); with --notify-url")
    parser.add_argument("--poll-interval", type=float, metavar="S",
                        help=f"--orion: polling period in simulated seconds (default {POLL_INTERVAL:g}); without --notify-url")


def client_from_args(args: argparse.Namespace):  # type: ignore[no-untyped-def]
    """An OrionClient; the token comes from a file or the environment, never from argv (it shows in ps).

    A URL that cannot work (``not-a-url``, ``ftp://...``, a port out of range) is a CommandError now,
    not a fault retried forever; a well-formed URL where nothing answers is Orion being down (retried)."""
    from transports.orion.client import OrionClient, Tenant

    parts = check_url("--orion", args.orion, ("http", "https"))
    api = _NGSI_PATH.search(parts.path)
    if api is not None:  # every request would go to /v2/.../v2/...: 400 for the whole run, as if Orion were down
        base = parts._replace(path=parts.path[: api.start()]).geturl()
        raise CommandError(f"--orion {args.orion!r}: give Orion's base URL, without /v2 (vcran adds /v2/entities "
                           f"and the rest itself): {base}")
    check_scope(args.service, args.service_path)
    token = os.environ.get(TOKEN_ENV) or None
    if args.token_file is not None:
        try:
            token = args.token_file.read_text(encoding="utf-8").strip() or None
        except (OSError, UnicodeDecodeError) as exc:
            raise CommandError(f"cannot read --token-file {args.token_file}: "
                               f"{getattr(exc, 'strerror', None) or 'not UTF-8 text'}") from None
    return OrionClient(args.orion, Tenant(args.service, args.service_path, token))


#: The NGSI v2 API at the end of a URL's path (``/v2``, ``/v2/entities/robot_1``): what vcran adds to ``--orion``.
_NGSI_PATH = re.compile(r"/v2(/(entities|subscriptions|registrations|types|op|version)\b.*)?/*$", re.IGNORECASE)


def check_scope(service: str | None, service_path: str | None) -> None:
    """A CommandError for a tenant or service path Orion refuses in every request vcran makes (400), by
    Orion's own rules (:mod:`vcran.core.orion_rules`, which vcran's broker applies): they would otherwise
    look like an Orion that is down, for the whole run. vcran writes entities, so one plain path."""
    from vcran.core.orion_rules import service_path_error, split_service_paths, tenant_error, update_service_path_error

    if service is not None:
        error = tenant_error(service.lower())
        if error is not None:
            raise CommandError(f"--service {service!r}: {error}")
    if service_path is not None and service_path.strip():
        paths = split_service_paths(service_path)
        error = service_path_error(paths[0]) if len(paths) == 1 else None
        if error is None and (len(paths) > 1 or update_service_path_error(paths[0]) is not None):
            error = "Bad Character in Service-Path (vcran writes entities: one plain path)"
        if error is not None:
            raise CommandError(f"--service-path {service_path!r}: {error}")


def check_url(option: str, url: str, schemes: tuple[str, ...]) -> SplitResult:
    """``url`` split, or a CommandError saying what is wrong with it: scheme, host, port, extras."""
    expected = " or ".join(f"{scheme}://HOST[:PORT][/PATH]" for scheme in schemes)
    try:
        parts = urlsplit(url)
        parts.port  # noqa: B018 - raises ValueError for a port out of range or not a number
    except ValueError as exc:
        raise CommandError(f"{option} {url!r}: not a valid URL ({exc}); expected {expected}") from None
    if parts.scheme.lower() not in schemes or not parts.hostname:
        raise CommandError(f"{option} {url!r}: not a valid URL; expected {expected}")
    if parts.query or parts.fragment or any(c.isspace() for c in url):
        raise CommandError(f"{option} {url!r}: a query, fragment or white space has no place here; expected {expected}")
    import httpx  # as the client will read it: urlsplit takes a host httpx refuses (256.0.0.1)

    try:
        httpx.URL(url)
    except httpx.InvalidURL as exc:
        raise CommandError(f"{option} {url!r}: not a valid URL ({exc}); expected {expected}") from None
    return parts


def check_notify_url(url: str) -> None:
    """``--notify-url``: vcran's listener speaks plain HTTP, and Orion must be able to POST there."""
    if check_url("--notify-url", url, ("http",)).port == 0:
        raise CommandError(f"--notify-url {url!r}: port 0 is no address Orion can send to")


def setup_logging(quiet: bool = False) -> None:
    logging.basicConfig(level=logging.ERROR if quiet else logging.INFO, stream=sys.stderr,
                        format="vcran: %(message)s")
    logging.getLogger("httpx").setLevel(logging.WARNING)  # it would log every request URL
