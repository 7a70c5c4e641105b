"""The transport interface (defined in :mod:`vcran.core.wire`, so the simulation needs only the core)."""

from vcran.core.wire import Deliver, Transport

__all__ = ["Deliver", "Transport"]
