"""Transports connect vcran's RAN to a fleet manager (docs/contract.md §1): scripted, replay and live Orion.

Not to be confused with the unrelated PyPI package named ``transports``; this one ships inside vcran.
"""

from transports.base import Deliver, Transport

__all__ = ["Deliver", "Transport"]
