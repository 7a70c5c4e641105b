"""vcran's own NGSI v2 broker: an in-memory stand-in for a FIWARE Orion Context Broker 4.7.

For trying live mode without Orion (``vcran broker``) and for testing it over real HTTP. Data lives in
memory only. The engine (:class:`Broker`) is pure; :func:`start_broker` runs it behind an HTTP server
with a notifier. What it implements and where it differs from Orion: docs/broker.md.
"""

from __future__ import annotations

from typing import Any

from vcran.broker.engine import Broker
from vcran.broker.protocol import NgsiError, Notification, Outcome, Request, Response

__all__ = ["Broker", "BrokerHandle", "NgsiError", "Notification", "Outcome", "Request", "Response", "start_broker"]


def __getattr__(name: str) -> Any:
    # The HTTP shell needs httpx (for notifications); import it only when asked for, so that the
    # pure engine stays importable without it.
    if name in ("start_broker", "BrokerHandle"):
        from vcran.broker import server

        return getattr(server, name)
    raise AttributeError(f"module 'vcran.broker' has no attribute {name!r}")
