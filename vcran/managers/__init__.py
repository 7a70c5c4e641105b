"""Fleet managers that ship with vcran (docs/contract.md §9): subclass one, or write your own :class:`vcran.FleetManager`.

Like the core they are pure (no SimPy, no clock, no files): they act through their handle only, so the
same object runs in simulated time and against a real Orion.
"""

from vcran.managers.dispatcher import Dispatcher

__all__ = ["Dispatcher"]
