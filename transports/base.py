"""The transport interface (defined in :mod:`vcran.wire`, so the simulation needs only the core)."""

from vcran.wire import Deliver, Transport

__all__ = ["Deliver", "Transport"]
