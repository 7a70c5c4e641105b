"""The transport interface: two methods and ``close()``, after httpx's ``BaseTransport``.

A transport is attached to a running SimPy environment once. From then on it hands inbound messages to
``deliver`` at the simulated time they enter (a scripted transport schedules them; a live one stamps them
with ``env.now`` when they arrive), and it receives every outbound message through :meth:`send`, already
stamped with simulated time. Everything else (recording, verification) is a wrapper around another
transport, never a flag inside one.
"""

from __future__ import annotations

from collections.abc import Callable

import simpy

from vcran.wire import Inbound, Outbound

Deliver = Callable[[Inbound], None]


class Transport:
    """Base class; subclasses override :meth:`attach` and :meth:`send`, and :meth:`close` if they hold resources."""

    def attach(self, env: simpy.Environment, deliver: Deliver) -> None:
        """Start delivering inbound messages into ``env`` through ``deliver``."""
        raise NotImplementedError

    def send(self, out: Outbound) -> None:
        """Take one outbound message (a Publish or a telemetry Frame)."""
        raise NotImplementedError

    @property
    def exhausted(self) -> bool:
        """True once no further inbound message can come (lets a run stop when idle)."""
        return False

    def close(self) -> None:
        """Release what the transport holds; called once, after the run."""
