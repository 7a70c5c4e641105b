"""What a broker does to a script's messages, whatever their protocol: late, out of order, twice, never.

The perturbations both fuzzers share (OPIL's :mod:`vcran.testing.scripts`, VDA 5050's
:mod:`vcran.testing.vda5050.fuzz`): frozen dataclasses with plain reprs that name a script entry by its
index, so hypothesis shrinks a failure to the few that matter. Each fuzzer plays them on its own form of
the script; an index wraps, so every operation applies to something.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class Delay:
    """Entry ``index`` arrives ``by`` seconds late (it may overtake later entries, or miss a deadline)."""

    index: int
    by: float


@dataclass(frozen=True, slots=True)
class Swap:
    """Entries ``index`` and ``index + offset`` arrive in each other's time slots (a reordering)."""

    index: int
    offset: int


@dataclass(frozen=True, slots=True)
class Duplicate:
    """Entry ``index`` arrives again ``after`` seconds later (a re-send, or a polling re-read)."""

    index: int
    after: float


@dataclass(frozen=True, slots=True)
class Drop:
    """Entry ``index`` never arrives (a value overwritten between two polls, a message lost)."""

    index: int
