"""A fleet manager in the loop, in simulated time, whatever the protocol (docs/contract.md §9): jobs, timers, hooks.

:class:`Loop` implements the transport interface (:class:`vcran.core.wire.Transport`), so the model is
the same as under a script or a replay. It starts the manager, hands it the scenario's jobs at their
times, gives it a handle whose timers are SimPy events, and runs every hook so that an exception says
which hook raised it and when. What travels between the manager and the robots goes over a link
(:class:`~vcran.sim.link.Link`: latency, jitter, polling, ``link_down``); what the manager hears of it
and how it writes are the protocol's: a protocol's loop subclasses :class:`Loop` with :meth:`notified`,
:meth:`make_handle` and its link's settings (OPIL: :class:`vcran.sim.opil.loop.ClosedLoop`). Every
callback runs at a simulated instant with its own priority (vcran/sim/timing.py: updates, then jobs,
then timers), so the whole loop is deterministic (docs/contract.md §5).

A closed-loop run is over (``until_idle``) only when nothing is left to do on the manager's side either:
no job still to come or still open, no timer pending, nothing the manager wrote still on its way, and
no update other than periodic telemetry still on its way to the manager (:attr:`Loop.exhausted`).
"""

from __future__ import annotations

import inspect
import math
import random
from collections.abc import Callable, Iterator
from typing import Any, Protocol

import simpy

from vcran.core.jobs import JobBook, Log
from vcran.core.manager import Fleet, Handle, Manager, Timer
from vcran.core.scenario import Job, Scenario
from vcran.core.wire import Deliver, Outbound, Transport
from vcran.sim.link import Link
from vcran.sim.timing import JOB, TIMER, at

#: How the note on an exception a fleet manager raised begins (``in fleet manager Mine: on_job at t=1.0``).
MANAGER_NOTE = "in fleet manager "


def manager_note(exc: BaseException) -> str | None:
    """The note saying which hook of the fleet manager raised ``exc`` and when, or None: not the manager's."""
    return next((n for n in getattr(exc, "__notes__", ()) if n.startswith(MANAGER_NOTE)), None)


class ManagerLink(Protocol):
    """What a closed loop needs of the link between its manager and the robots (:class:`Link`, or a live
    broker's): the manager's writes, keyed by robot and attribute (a topic), and whether anything is on its way."""

    def write(self, robot: str, attribute: str, message: Any, raw: Any = None) -> None: ...

    @property
    def inbound_idle(self) -> bool: ...

    @property
    def outbound_idle(self) -> bool: ...


class Loop(Transport):
    """The fleet's transport in a closed loop. ``log`` receives the ``job_*`` events (events.jsonl).

    A protocol's loop provides :meth:`make_handle` (its manager's handle on this loop) and
    :meth:`notified` (a batch of the robots' publications reaches the manager), and says which of its
    attributes are :attr:`periodic` (they never keep a run from ending idle) and of which it keeps
    :attr:`every` value while a link is down (the others coalesce to the latest).
    """

    #: Attributes published periodically whatever happens (:class:`Link`'s ``periodic``).
    periodic: frozenset[str] = frozenset()
    #: Attributes of which every value, not only the latest, waits out a ``link_down`` (:class:`Link`'s ``every``).
    every: frozenset[str] = frozenset()
    #: Whether the link holds what the manager writes as Orion does (:class:`Link`'s ``holds``; False: a broker's).
    holds: bool = True

    def __init__(self, scenario: Scenario, manager: Manager, log: Log) -> None:
        self.scenario, self.manager = scenario, manager
        self.fleet = self.make_fleet(scenario)
        self.jobs = JobBook(log)
        self.link: ManagerLink | None = None
        self.handle: Handle | None = None
        self.timers = 0
        self._workload: Iterator[Job] = scenario.workload()
        self._jobs_to_come = True

    def attach(self, env: simpy.Environment, deliver: Deliver) -> None:
        seed = self.scenario.settings.seed
        self.link = self.make_link(env, deliver)
        self.handle = self.make_handle(env, random.Random(f"manager:{seed}"))
        self.manager._bind(self.fleet, self.handle)
        self._next_job(env)
        self._call("on_start")

    def make_fleet(self, scenario: Scenario) -> Any:
        """What the manager is told of the fleet at the start (``manager.fleet``, its handle's too): the shared
        :class:`Fleet`; a protocol whose managers know the fleet otherwise overrides this (VDA 5050: vehicles
        by serial number, :class:`vcran.core.vda5050.fleet.MasterFleet`)."""
        return Fleet.of(scenario)

    def make_handle(self, env: simpy.Environment, rng: random.Random) -> Handle:
        """The manager's handle on this loop, drawing from ``rng``."""
        raise NotImplementedError

    def make_link(self, env: simpy.Environment, deliver: Deliver) -> ManagerLink:
        """The link between manager and robots, in simulated time. ``vcran manage`` puts a real Orion
        here (:class:`transports.orion.manage.OrionManagerLink`): anything with :meth:`Link.write`,
        ``inbound_idle`` and ``outbound_idle`` that calls :meth:`notified` with what reaches the manager."""
        return Link(env, tuple(r.id for r in self.scenario.robots), self.scenario.link, random.Random(f"link:{self.scenario.settings.seed}"),
                    deliver, self.notified, periodic=self.periodic, every=self.every, holds=self.holds)

    def notified(self, batch: list[Outbound]) -> None:
        """One batch of the robots' publications reaches the manager (the protocol's hooks)."""
        raise NotImplementedError

    def send(self, out: Outbound) -> None:
        assert isinstance(self.link, Link)
        self.link.publish(out)

    def outage(self, robot: str, until: float) -> bool:
        """``link_down`` (docs/contract.md §4) is the link's: what was written to the robot waits, and what the robot
        publishes (its rows of the fleet's frames too) waits (:meth:`Link.outage`)."""
        if not isinstance(self.link, Link):
            return False
        self.link.outage(robot, until)
        return True

    @property
    def exhausted(self) -> bool:
        link = self.link
        return (not self._jobs_to_come and self.jobs.open == 0 and self.timers == 0
                and link is not None and link.inbound_idle and link.outbound_idle)

    # --- what reaches the manager -----------------------------------------------------------------------

    def _next_job(self, env: simpy.Environment) -> None:
        """Schedule the next job's arrival. Hooks run from event callbacks, never inside a SimPy process,
        so an exception the manager raises reaches the caller as raised (a process would wrap it)."""
        job = next(self._workload, None)
        if job is None:
            self._jobs_to_come = False
            return
        at(env, job.t, JOB).callbacks.append(lambda _: self._arrive(env, job))

    def _arrive(self, env: simpy.Environment, job: Job) -> None:
        self.jobs.arrived(env.now, job)
        self._call("on_job", job)
        self._next_job(env)

    def _call(self, hook: str, *args: Any) -> None:
        """Run one of the manager's hooks; an exception says where and when it happened, and ends the run."""
        self._run(getattr(self.manager, hook), args, {}, hook)

    def _run(self, fn: Callable[..., Any], args: tuple[Any, ...], kwargs: dict[str, Any], what: str) -> None:
        try:
            returned = fn(*args, **kwargs)
            if returned is not None and (inspect.isgenerator(returned) or inspect.isawaitable(returned)):
                _refuse_waiting(returned, what)
        except (Exception, SystemExit) as exc:
            assert self.handle is not None
            note = f"{MANAGER_NOTE}{type(self.manager).__name__}: {what} at t={self.handle.now!r}"
            if isinstance(exc, SystemExit):
                # The manager's bug like any other: it ends the run, not the process hosting it (vcran run,
                # which exited with the manager's code and left its folder incomplete without a word; a
                # sweep's worker; a test calling vcran.simulate)
                error = RuntimeError(f"{what} called sys.exit({exc.code!r})")
                error.add_note(note)
                raise error from exc
            exc.add_note(note)
            raise


def _refuse_waiting(returned: Any, what: str) -> None:
    """A hook or timer that returned a generator (a SimPy habit: ``yield`` to wait) or a coroutine
    (``async def``) did nothing at all; say so instead of silently dropping its work."""
    kind = "generator" if inspect.isgenerator(returned) else "coroutine" if inspect.iscoroutine(returned) else "awaitable"
    close = getattr(returned, "close", None)
    if close is not None:
        close()  # no "never awaited" warning on top of the error
    name = what.removeprefix("timer ")
    raise TypeError(f"{name} returned a {kind}: hooks and timers run to the end at one simulated instant; to wait, "
                    "schedule a callback (self.handle.call_later) instead of yield or await")


class InSimTime:
    """The shared primitives of a manager's handle in simulated time (mixed into a protocol's handle, e.g.
    :class:`vcran.sim.opil.loop.SimHandle`): ``now`` is the environment's, timers are SimPy events at
    priority TIMER, each counted by the loop until it has run or is cancelled."""

    env: simpy.Environment
    _loop: Loop

    @property
    def now(self) -> float:
        return self.env.now

    def call_at(self, when: float, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Timer:
        if not math.isfinite(when):  # a NaN breaks the order of SimPy's event heap; inf never comes
            raise ValueError(f"call_at({when}): not a finite time")
        if when < self.env.now:
            raise ValueError(f"call_at({when}): that is in the past (now {self.env.now})")
        timer = _SimTimer(when, self._loop)
        self._loop.timers += 1
        at(self.env, when, TIMER).callbacks.append(lambda _: timer.fire(fn, args, kwargs))
        return timer


class _SimTimer(Timer):
    __slots__ = ("_loop", "_pending")

    def __init__(self, when: float, loop: Loop) -> None:
        super().__init__(when)
        self._loop, self._pending = loop, True

    def cancel(self) -> None:
        super().cancel()
        self._settle()

    def fire(self, fn: Callable[..., Any], args: tuple[Any, ...], kwargs: dict[str, Any]) -> None:
        if not self.cancelled:
            self._settle()
            self._loop._run(fn, args, kwargs, f"timer {getattr(fn, '__name__', fn)!s}")

    def _settle(self) -> None:
        if self._pending:
            self._pending = False
            self._loop.timers -= 1
