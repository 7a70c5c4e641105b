"""The scripted transport: the scenario's message script plays the fleet manager (the original VC-RAN's JMeter file).

Inbound messages enter at their script times, as fast as the simulation runs. Outbound messages are kept
the way Orion keeps them, as the fleet's entities: the latest value per robot and attribute (``latest``,
``last_frame``), plus how many of each were sent (``counts``), so memory stays flat however long the
run; the full outbound stream is the recording wrapper's business. A test or a user embedding vcran
reads the final entity state from here.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable

import simpy

from transports.base import Deliver, Transport
from vcran.core.opil.messages import Message
from vcran.core.scenario import Script, ScriptEntry
from vcran.core.wire import Frame, Outbound, Publish
from vcran.sim.timing import INBOUND, at


class ScriptedTransport(Transport):
    def __init__(self, script: Iterable[ScriptEntry], *, frames: bool = True) -> None:
        """``script`` must be in time order (``Scenario.messages()`` is); it is consumed lazily.
        ``frames=False``: the fleet's samples are not kept, OPIL's ``current_motion`` (``last_frame`` stays None)
        or VDA 5050's ``visualization``, so a run that records only a trace does not sample the fleet every
        tick (:attr:`Transport.wants_frames`, :attr:`Transport.wants_visualization`)."""
        self.wants_frames = self.wants_visualization = frames
        self._runs = (script if isinstance(script, Script) else Script.of(script)).runs()
        self._exhausted = False
        self.latest: dict[tuple[str, str], Message] = {}
        self.last_frame: Frame | None = None
        self.counts: Counter[str] = Counter()

    def attach(self, env: simpy.Environment, deliver: Deliver) -> None:
        env.process(self._play(env, deliver))

    def _play(self, env: simpy.Environment, deliver: Deliver):  # type: ignore[no-untyped-def]
        now = env.now  # the time this process last woke at: an ``at`` event lands exactly on its time
        for t, run in self._runs:
            if t > now:
                now = t
                yield at(env, t, INBOUND)
            for inbound in run:
                deliver(inbound)
        self._exhausted = True

    @property
    def exhausted(self) -> bool:
        return self._exhausted

    def send(self, out: Outbound) -> None:
        if isinstance(out, Frame):
            self.last_frame = out
            self.counts["current_motion"] += len(out.robots)
        else:
            assert isinstance(out, Publish)
            self.latest[(out.robot, out.attribute)] = out.message
            self.counts[out.attribute] += 1
