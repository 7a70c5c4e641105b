"""A recording transport: a wrapper that writes every message to a trace, then passes it on (docs/contract.md §6)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import simpy

from transports.base import Deliver, Transport
from vcran.core.motion import Leg
from vcran.core.wire import Frame, Inbound, Outbound, Publish


class TraceSink(Protocol):
    """Where records go: :class:`vcran.io.trace.TraceWriter` (files), or memory (``vcran.simulate``)."""

    def inbound(self, t: float, inbound: Inbound) -> None: ...
    def publish(self, out: Publish) -> None: ...
    def frame(self, frame: Frame) -> None: ...
    #: False if :meth:`frame` ignores frames (a file trace: the leg log determines them).
    wants_frames: bool
    def leg(self, robot: int, leg: Leg, t: float) -> None: ...
    def halt(self, robot: int, t: float) -> None: ...
    def abandon(self, robot: int, t: float, pose: tuple[float, float, float]) -> None: ...
    def end(self, t: float) -> None: ...
    def close(self) -> None: ...


class RecordingTransport(Transport):
    def __init__(self, inner: Transport, writer: TraceSink, *, after_frame: Callable[[], None] | None = None) -> None:
        """``after_frame`` runs after each telemetry frame is written (live mode flushes the files there)."""
        self.inner, self.writer = inner, writer
        self._after_frame = after_frame
        self._env: simpy.Environment | None = None

    def attach(self, env: simpy.Environment, deliver: Deliver) -> None:
        self._env = env

        def recorded(inbound: Inbound) -> None:
            self.writer.inbound(env.now, inbound)
            deliver(inbound)

        self.inner.attach(env, recorded)

    def send(self, out: Outbound) -> None:
        if isinstance(out, Frame):
            self.writer.frame(out)
            if self._after_frame is not None:
                self._after_frame()
        else:
            self.writer.publish(out)
        self.inner.send(out)

    @property
    def wants_frames(self) -> bool:  # type: ignore[override]
        return self.inner.wants_frames or self.writer.wants_frames or self._after_frame is not None

    @property
    def wants_visualization(self) -> bool:  # type: ignore[override]
        """The inner transport's: a trace does not record visualization (the leg log determines it)."""
        return self.inner.wants_visualization

    @property
    def exhausted(self) -> bool:
        return self.inner.exhausted

    def outage(self, robot: str, until: float) -> bool:
        return self.inner.outage(robot, until)

    def close(self) -> None:
        self.writer.close()
        self.inner.close()
