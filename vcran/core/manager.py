"""A fleet manager in the loop, whatever the protocol (docs/contract.md §9): its fleet, its hooks, its handle's shared part.

Modelled on SimPy's process functions and pytest's hooks: a few methods with plain arguments, no
framework to learn. vcran calls two hooks on every :class:`Manager`: :meth:`~Manager.on_start` once,
before anything else, with ``self.fleet`` and ``self.handle`` set, and :meth:`~Manager.on_job` when a job
of the scenario's workload reaches it. Its :class:`Handle` gives it the time, timers, a seeded random
generator and the job reports. What it hears of the robots and what it writes to them are the protocol's:
OPIL's :class:`vcran.FleetManager` adds ``on_update`` and a handle that writes motion and action
assignments (:mod:`vcran.core.opil.manager`). The same manager object runs in simulated time
(:func:`vcran.simulate`, :mod:`vcran.sim.loop`) and in wall-clock time against a real broker: only the
handle's primitives differ. Everything here is pure (no SimPy, no clock).
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any, NoReturn

from vcran.core.jobs import JobBook
from vcran.core.scenario import Job, LinkSettings, RobotConfig, Scenario, Settings, StationConfig
from vcran.core.traffic.roadmap import Roadmap


class ReadOnlyDict(dict[str, float]):
    """A dict that refuses every write: the fleet's ``settings.durations`` (docs/contract.md §9). A dict still, so the
    fleet pickles, deep-copies (a copy read-only too), goes to ``json.dumps`` and ``dataclasses.asdict`` as
    before it was read-only, which a ``MappingProxyType`` could not; ``dict(d)`` is a copy one may change."""

    def _refuse(self, *_args: Any, **_kwargs: Any) -> NoReturn:
        raise TypeError("the fleet is read-only: its settings.durations does not support item assignment "
                        "(dict(self.fleet.settings.durations) is a copy you may change)")

    __setitem__ = __delitem__ = __ior__ = _refuse  # type: ignore[assignment]
    clear = pop = popitem = setdefault = update = _refuse  # type: ignore[assignment]

    def __reduce__(self) -> tuple[type[ReadOnlyDict], tuple[dict[str, float]]]:
        return type(self), (dict(self),)  # not dict's own, which refills the copy item by item


@dataclass(frozen=True)
class Fleet:
    """What a fleet manager is told at the start: the robots, the stations, the settings, the link, and the
    roadmap robots drive on (docs/contract.md §12; None: none, robots drive anywhere)."""

    robots: tuple[RobotConfig, ...]
    stations: tuple[StationConfig, ...]
    settings: Settings
    link: LinkSettings
    roadmap: Roadmap | None = None
    _robots: dict[str, RobotConfig] = field(init=False, repr=False, compare=False)
    _stations: dict[str, StationConfig] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_robots", {r.id: r for r in self.robots})
        object.__setattr__(self, "_stations", {s.id: s for s in self.stations})

    @classmethod
    def of(cls, scenario: Scenario) -> Fleet:
        """The scenario's fleet, read-only: its one mutable part, ``settings.durations``, is the model's
        too, so a manager writing to it changed the simulated actions and the caller's scenario."""
        durations = ReadOnlyDict(scenario.settings.durations)
        return cls(scenario.robots, scenario.stations, replace(scenario.settings, durations=durations), scenario.link,
                   scenario.roadmap)

    @property
    def robot_ids(self) -> tuple[str, ...]:
        return tuple(self._robots)

    def robot(self, robot_id: str) -> RobotConfig:
        try:
            return self._robots[robot_id]
        except KeyError:
            raise KeyError(f"no robot {robot_id!r} in this fleet") from None

    def station(self, station_id: str) -> StationConfig:
        try:
            return self._stations[station_id]
        except KeyError:
            raise KeyError(f"no station {station_id!r} in this fleet") from None

    def dock(self, station_id: str) -> tuple[float, float, float | None]:
        """Where a robot stands to load or unload at a station: its ``dock``, else its position."""
        s = self.station(station_id)
        return s.dock if s.dock is not None else (s.position[0], s.position[1], None)


class Timer:
    """A callback scheduled with :meth:`Handle.call_at`; :meth:`cancel` stops it if it has not run."""

    __slots__ = ("when", "cancelled")

    def __init__(self, when: float) -> None:
        self.when = when
        self.cancelled = False

    def cancel(self) -> None:
        self.cancelled = True


class Handle:
    """How a fleet manager acts on the fleet, whatever the protocol: time, timers, random, job reports.

    Subclasses provide the two primitives :attr:`now` and :meth:`call_at` (in simulated time,
    :class:`vcran.sim.loop.InSimTime`); a protocol's handle adds what its manager writes to the robots and
    reads of them (OPIL: :class:`vcran.core.opil.manager.OpilHandle`). ``random`` is seeded from the
    scenario (``random.Random("manager:{seed}")``): draw from it, never from the global generator, and a
    run stays byte-identical (docs/contract.md §5).
    """

    def __init__(self, fleet: Fleet, jobs: JobBook, rng: random.Random) -> None:
        self.fleet = fleet
        self.random = rng
        self._jobs = jobs

    # --- primitives --------------------------------------------------------------------------------------

    @property
    def now(self) -> float:
        """The current simulated time, in seconds."""
        raise NotImplementedError

    def call_at(self, when: float, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Timer:
        """Call ``fn(*args, **kwargs)`` at simulated time ``when`` (not before :attr:`now`)."""
        raise NotImplementedError

    # --- built on them -----------------------------------------------------------------------------------

    def call_later(self, delay: float, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Timer:
        """Call ``fn(*args, **kwargs)`` ``delay`` seconds from now."""
        if delay < 0:
            raise ValueError(f"negative delay {delay}")
        if not math.isfinite(delay):  # NaN passes the test above; inf would never run
            raise ValueError(f"call_later: the delay must be a finite number of seconds, got {delay}")
        return self.call_at(self.now + delay, fn, *args, **kwargs)

    def job_done(self, job: Job | str) -> None:
        """Report ``job`` completed (a ``job_completed`` event; its lead time ends now)."""
        self._jobs.completed(self.now, job)

    def job_failed(self, job: Job | str, reason: str) -> None:
        """Report ``job`` failed for ``reason`` (a ``job_failed`` event); use one of
        :data:`vcran.core.jobs.FAILURE_REASONS` where one fits (``"timeout"``, ``"action_failed"``, ...)."""
        if not isinstance(reason, str):  # it is written to events.jsonl and JobRecord.reason as a string
            raise TypeError(f"job_failed: reason must be a string, got {type(reason).__name__}")
        self._jobs.failed(self.now, job, reason)

    def _robot(self, robot: str) -> str:
        self.fleet.robot(robot)  # a write to an entity Orion does not hold fails (Orion answers 404)
        return robot


class Manager:
    """A fleet manager, whatever the protocol: subclass a protocol's (OPIL: :class:`vcran.FleetManager`)
    and override the hooks you need; the defaults do nothing.

    vcran sets :attr:`fleet` and :attr:`handle` before it calls :meth:`on_start`. Hooks run at simulated
    instants in a documented order (docs/determinism.md) and must not block: to wait, schedule a
    callback with ``self.handle.call_later``.
    """

    fleet: Fleet
    handle: Handle

    def on_start(self) -> None:
        """The run starts (simulated time 0): ``self.fleet`` and ``self.handle`` are set."""

    def on_job(self, job: Job) -> None:
        """``job`` has arrived: it is the manager's to assign (and to report done or failed)."""

    def _bind(self, fleet: Fleet, handle: Handle) -> None:
        self.fleet, self.handle = fleet, handle
