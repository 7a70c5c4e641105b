"""The replay transport: feeds a recorded trace's inbound records back at their recorded times (docs/contract.md §6).

The trace is read lazily, line by line, so a replay of a long run needs no more memory than the run did.
Outbound messages are dropped here; verification compares the files the replay writes.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import simpy

from transports.base import Deliver, Transport
from vcran.core.opil.messages import INBOUND
from vcran.core.opil.plain import from_plain
from vcran.core.wire import Inbound, Outbound
from vcran.io.trace import read_header, records
from vcran.sim.timing import INBOUND as INBOUND_PRIORITY
from vcran.sim.timing import at

#: What a VDA 5050 vehicle receives (docs/vda5050.md), recorded raw: its glue decodes and validates it.
VDA5050_TOPICS = ("order", "instantActions")


class TraceError(ValueError):
    """A trace that cannot be replayed; the message names the file and line."""


class ReplayTransport(Transport):
    #: Outbound messages are dropped (the replay's own trace records them): no frames to sample, no visualization.
    wants_frames = wants_visualization = False

    def __init__(self, trace: Path) -> None:
        self.trace = trace
        self._exhausted = False
        options = read_header(trace).get("options", {})
        #: A closed loop's link_down cut the link between manager and RAN, outside what the trace records
        #: (the RAN's own inbound and outbound): the records already carry it, the replayed RAN holds nothing.
        #: A replay's trace says so too (:meth:`options`), so a replay of it holds nothing either. A VDA 5050
        #: closed loop's trace says ``link_outside = false``: there the vehicle cut its own link (what reached it
        #: meanwhile is recorded, and lost: vcran.sim.vda5050.loop), and its replay cuts it again.
        self.link_outside = isinstance(options, dict) and options.get(
            "link_outside", options.get("transport") == "loop") is True

    def options(self) -> dict[str, object]:
        """The ``options`` of a replay's trace header: where it came from, and :attr:`link_outside`."""
        options: dict[str, object] = {"transport": "replay", "source": str(self.trace)}
        if self.link_outside:
            options["link_outside"] = True
        return options

    def attach(self, env: simpy.Environment, deliver: Deliver) -> None:
        env.process(self._play(env, deliver))

    def _play(self, env: simpy.Environment, deliver: Deliver):  # type: ignore[no-untyped-def]
        for t, inbound in inbound_records(self.trace):
            if t > env.now:
                yield at(env, t, INBOUND_PRIORITY)
            deliver(inbound)
        self._exhausted = True

    @property
    def exhausted(self) -> bool:
        return self._exhausted

    def send(self, out: Outbound) -> None:
        pass

    def outage(self, robot: str, until: float) -> bool:
        return self.link_outside


def inbound_records(trace: Path) -> Iterator[tuple[float, Inbound]]:
    """``(t, Inbound)`` for every ``in`` record, decoded from its plain value (or kept raw)."""
    last = 0.0
    for n, record in records(trace, ("in",)):
        if record.get("dir") != "in":
            continue
        t, attr = record.get("t"), record.get("attr")
        where = f"{trace}:{n}"
        if not isinstance(t, (int, float)) or t < last:
            raise TraceError(f"{where}: time {t!r} is not a number at or after {last}")
        if attr in VDA5050_TOPICS and "raw" in record:  # a VDA 5050 message as on the wire: the vehicle decodes it
            last = float(t)
            yield last, Inbound(str(record.get("robot")), attr, None, record["raw"])
            continue
        if attr not in INBOUND:
            raise TraceError(f"{where}: unknown inbound attribute {attr!r}")
        last = float(t)
        yield last, Inbound(str(record.get("robot")), attr, *_payload(where, attr, record))


def _payload(where: str, attr: str, record: dict[str, Any]) -> tuple[Any, Any]:
    if "value" in record:
        try:
            return from_plain(INBOUND[attr], record["value"]), None
        except ValueError as exc:
            raise TraceError(f"{where}: {attr}: {exc}") from None
    if "raw" in record:
        return None, record["raw"]
    raise TraceError(f"{where}: an in record needs value or raw")
