"""Run a scenario in process: :func:`simulate` and its :class:`Result` (docs/contract.md §9, "The API"; docs/library.md).

One path for every in-process run: a scenario with a message script plays it (as ``vcran run`` always
did); a scenario with a fleet manager, named in the scenario or passed in, runs a closed loop
(OPIL's :class:`vcran.sim.opil.loop.ClosedLoop`, VDA 5050's :class:`vcran.sim.vda5050.loop.MasterLoop`). With ``out`` the usual run folder is written and the result reads
its events and telemetry back on demand; without, nothing touches the disk and everything stays in
memory. ``vcran run`` is a thin shell on :func:`run`.
"""

from __future__ import annotations

import importlib
import os
import sys
from collections.abc import Callable, Collection
from dataclasses import dataclass, field
from functools import cached_property, partial
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeAlias

from transports.scripted import ScriptedTransport
from vcran.core.scenario import VDA5050, ManagerSpec, Scenario
from vcran.core.validity import validate
from vcran.core.wire import Transport
from vcran.io.scenario_file import ScenarioError, load
from vcran.io.sinks import FolderSinks, Frames, LegRows, MemorySinks
from vcran.io.trace import event_records, events_beside, long_table, telemetry_table, trace_in
from vcran.runner import CLOSED_LOOP, check_protocol, execute
from vcran.sim.model import Model

if TYPE_CHECKING:  # the closed loop is imported when a run has a fleet manager (a scripted run never does)
    import numpy as np

    from vcran.core.jobs import JobRecord, Log
    from vcran.core.manager import Manager
    from vcran.sim.loop import Loop

#: What names a fleet manager: an instance, a subclass of its protocol's kind (an OPIL scenario's
#: :class:`vcran.FleetManager`, a VDA 5050 one's :class:`vcran.core.vda5050.master.Master`), or ``"module:Class"``.
ManagerLike: TypeAlias = "Manager | type[Manager] | str"


class ManagerError(ValueError):
    """A fleet manager that cannot be found or built; the message names it and why."""


@dataclass(frozen=True, eq=False)
class Result:
    """What a run produced. ``summary`` is summary.json as a dict; ``jobs`` one :class:`JobRecord` per
    job that reached the manager, in arrival order; ``out`` the run folder, or None for an in-memory
    run. ``events`` and ``telemetry`` are read from the folder on first use when there is one."""

    summary: dict[str, Any]
    jobs: tuple[JobRecord, ...]
    out: Path | None
    wall_seconds: float
    robots: tuple[str, ...]
    #: How many events the run wrote (``len(events)`` without reading them back).
    event_count: int
    _events: list[dict[str, Any]] | None = field(default=None, repr=False)
    #: An in-memory run's telemetry, as it kept it (:class:`vcran.io.sinks.MemorySinks`).
    _trace: Frames | LegRows | None = field(default=None, repr=False)
    #: The scenario that ran: the loop properties judge a job's failure against its fleet and stations
    #: (:mod:`vcran.testing.loop`).
    scenario: Scenario | None = field(default=None, repr=False)

    @cached_property
    def events(self) -> list[dict[str, Any]]:
        """Every event (events.jsonl), one dict each: ``t``, ``robot``, ``event`` and its fields."""
        if self._events is not None:
            return self._events
        assert self.out is not None
        return list(event_records(events_beside(trace_in(self.out))))

    @cached_property
    def telemetry(self) -> np.ndarray:
        """Every robot's ``current_motion`` at every tick: a numpy structured array with the columns
        ``t``, ``robot``, ``x``, ``y``, ``theta``, ``v``, ``w``, one row per tick and robot (robots in
        fleet order). ``pandas.DataFrame(result.telemetry)`` makes it a table."""
        if self._trace is None:
            assert self.out is not None
            return telemetry_table(self.out)
        return long_table(self._trace.samples(len(self.robots)), self.robots)

    def job(self, job_id: str) -> JobRecord:
        """The record of job ``job_id``."""
        for record in self.jobs:
            if record.id == job_id:
                return record
        raise KeyError(f"no job {job_id!r} reached the fleet manager")

    @property
    def speed(self) -> float:
        """Simulated seconds per wall second."""
        return self.summary["sim_time"] / self.wall_seconds if self.wall_seconds > 0 else float("inf")


def simulate(scenario: str | Path | Scenario, *, manager: ManagerLike | None = None,
             out: str | Path | None = None) -> Result:
    """Run ``scenario`` (a path, or a loaded :class:`vcran.Scenario`) in process and return its result.

    ``manager`` (an instance, a subclass built without arguments, or ``"module:Class"``, of the scenario's
    protocol's kind: a :class:`vcran.FleetManager` for OPIL robots, a :class:`vcran.core.vda5050.master.Master`
    for VDA 5050 vehicles) runs the scenario's jobs in a closed loop; without it the scenario's own
    ``[manager]`` does, or, if it names none, its message script plays. ``out`` writes the usual run
    folder (trace, telemetry, events, summary); without it no file is touched.

    Raises :class:`vcran.ScenarioError` for a scenario that cannot run this way (jobs but no manager, a
    script and a manager, a closed loop without a duration) or that the loader would refuse: a
    :class:`vcran.Scenario` built in code or made with ``dataclasses.replace`` is checked by the rules a
    file's reader applies (:func:`vcran.core.validity.validate`), told in the same words (script messages
    are checked as they are built). :class:`ManagerError` for a manager that cannot be built,
    :class:`vcran.RunFolderError` for an ``out`` that cannot receive a run (an existing folder that is not
    a run folder). An exception raised by the manager itself ends the run and propagates, with a note
    saying which hook raised it and when.
    """
    if isinstance(scenario, Scenario):
        _check_given(scenario)
    elif not isinstance(scenario, (str, Path)):
        raise TypeError(f"simulate: scenario must be a path or a vcran.Scenario, got {type(scenario).__name__}")
    return run(scenario, manager=manager, out=out)


def _check_given(sc: Scenario) -> None:
    """A scenario built or changed in code, checked by the model's rules (:func:`vcran.core.validity.validate`),
    the ones a file's reader applies: a value they refuse would otherwise fail deep inside the simulation, or
    not at all (a seed of 1.5). Told as its file would be, the file being the scenario as given."""
    try:
        problems = validate(sc)
    except (TypeError, ValueError, AttributeError) as exc:  # inside a part no rule looks into (a roadmap's node)
        raise ScenarioError(f"{sc.source} (as given): {type(exc).__name__}: {exc}") from None
    if problems:
        raise ScenarioError(f"{sc.source} (as given): {problems[0]}")


def run(
    scenario: str | Path | Scenario,
    *,
    manager: ManagerLike | None = None,
    out: str | Path | None = None,
    progress: Callable[[float, int], None] | None = None,
    on_start: Callable[[Model], None] | None = None,
) -> Result:
    """:func:`simulate`, with a progress observer (what ``vcran run`` shows) and ``on_start``, called with
    the model before it runs (``vcran run`` stops it there on a signal)."""
    sc = scenario if isinstance(scenario, Scenario) else load(scenario)
    if manager is not None or sc.manager is not None:
        check_protocol(sc, CLOSED_LOOP)
    fleet_manager, name = build_manager(manager, sc)
    _check_mode(sc, fleet_manager is not None)  # before the folder exists: a refused run writes nothing
    options: dict[str, Any] = ({"transport": "scripted"} if fleet_manager is None else
                               {"transport": "loop", "manager": name, "link": sc.link.as_dict()})
    if fleet_manager is not None and sc.settings.protocol == VDA5050:
        options["link_outside"] = False  # link_down cuts the vehicle's own link: a replay cuts it too (vcran.sim.vda5050.loop)
    folder = Path(out) if out is not None else None
    sinks = FolderSinks(folder, sc, options) if folder is not None else MemorySinks(sc)
    transport: Transport
    loop: Loop | None = None
    if fleet_manager is None:
        transport = ScriptedTransport(sc.messages(), frames=False)
    else:
        transport = loop = _loop(sc, fleet_manager, sinks.events.write)
    ran = execute(sc, transport, sinks, progress=progress, on_start=on_start,
                  summarize=Model.summary if loop is None else partial(loop_summary, loop=loop))
    memory = sinks if isinstance(sinks, MemorySinks) else None
    return Result(ran.summary, loop.jobs.records() if loop is not None else (), folder, ran.wall_seconds,
                  tuple(r.id for r in sc.robots), ran.events,
                  memory.events.events if memory is not None else None,
                  memory.trace if memory is not None else None, scenario=sc)


def _loop(sc: Scenario, manager: Manager, log: Log) -> Loop:
    """The closed loop of the scenario's protocol around ``manager`` (:func:`build_manager` matched the two)."""
    if sc.settings.protocol == VDA5050:
        from vcran.core.vda5050.master import Master
        from vcran.sim.vda5050.loop import MasterLoop

        assert isinstance(manager, Master)
        return MasterLoop(sc, manager, log)
    from vcran.core.opil.manager import FleetManager
    from vcran.sim.opil.loop import ClosedLoop

    assert isinstance(manager, FleetManager)
    return ClosedLoop(sc, manager, log)


def loop_summary(model: Model, loop: Loop) -> dict[str, Any]:
    """summary.json of a closed loop: the model's, with the jobs and each robot's share of time busy (docs/contract.md §9)."""
    summary = model.summary()
    t = model.env.now
    summary["jobs"] = loop.jobs.summary(t)
    shares = {r.id: model.busy(r.index) / t if t > 0 else 0.0 for r in model.robots}
    summary["utilisation"] = {"fleet": sum(shares.values()) / len(shares), "robots": shares}
    return summary


def _check_mode(sc: Scenario, managed: bool) -> None:
    """A scenario with jobs needs a manager; a manager needs a scenario without a script, with a duration."""
    if not managed:
        if sc.has_workload:
            raise ScenarioError(f"{sc.source}: the scenario has jobs but no fleet manager to give them to: name one "
                                "in [manager] or pass one (--manager module:Class)")
        return
    if sc.script or sc.cycles:
        raise ScenarioError(f"{sc.source}: a fleet manager plays the fleet manager's part; this scenario has a "
                            "[[script]] that would play it too (remove one)")
    if sc.settings.duration is None:
        raise ScenarioError(f"{sc.source}: [simulation]: a closed-loop run needs a duration (a manager that never "
                            "finishes would run forever; until_idle still ends it early)")


def build_manager(manager: ManagerLike | None, scenario: Scenario) -> tuple[Manager | None, str]:
    """The fleet manager to run and its name (``module:Class``), from the argument or the scenario; a
    class or ``module:Class`` gets the options :func:`manager_options` gives it, an instance none. Its kind
    is the scenario's protocol's: a :class:`vcran.FleetManager` for OPIL robots, a
    :class:`vcran.core.vda5050.master.Master` for VDA 5050 vehicles (:func:`manager_kind`)."""
    if manager is None and scenario.manager is None:
        return None, ""
    from vcran.core.manager import Manager

    kind, kind_name = manager_kind(scenario)
    if manager is None:
        assert scenario.manager is not None
        manager = scenario.manager.path
    if isinstance(manager, Manager):
        _check_kind(type(manager), scenario)
        _check_attributes(manager)
        return manager, _name(type(manager))
    cls = _import(manager) if isinstance(manager, str) else manager
    if not (isinstance(cls, type) and issubclass(cls, kind)):
        _check_kind(cls, scenario)
        raise ManagerError(f"fleet manager {manager!r} is not a {kind_name} subclass")
    options = manager_options(scenario.manager, cls)
    try:
        built = cls(**options)
    except Exception as exc:  # noqa: BLE001 - the class refusing its options (Dispatcher's ValueError) is bad input
        raise ManagerError(f"cannot build fleet manager {_name(cls)} with options {options}: "
                           f"{_described(exc)}") from None
    _check_attributes(built)
    return built, _name(cls)


def manager_kind(scenario: Scenario) -> tuple[type[Manager], str]:
    """The class a manager of ``scenario`` subclasses, and its public name: the protocol's (docs/contract.md §9, §11)."""
    if scenario.settings.protocol == VDA5050:
        from vcran.core.vda5050.master import Master

        return Master, "vcran.core.vda5050.master.Master"
    from vcran.core.opil.manager import FleetManager

    return FleetManager, "vcran.FleetManager"


def _check_kind(cls: object, scenario: Scenario) -> None:
    """A manager of the other protocol's kind is a ManagerError naming both kinds: a FleetManager would write
    OPIL tasks to VDA 5050 vehicles, a Master orders to OPIL robots, and neither would hear what they publish."""
    from vcran.core.manager import Manager

    kind, kind_name = manager_kind(scenario)
    if isinstance(cls, type) and issubclass(cls, Manager) and not issubclass(cls, kind):
        protocol = scenario.settings.protocol
        other = "a VDA 5050 master (vcran.core.vda5050.master.Master)" if protocol != VDA5050 else \
            "an OPIL fleet manager (vcran.FleetManager)"
        speaks = "VDA 5050" if protocol == VDA5050 else "OPIL"
        raise ManagerError(f"fleet manager {_name(cls)} is {other}; this scenario's robots speak {speaks} "
                           f"([simulation] protocol = {protocol!r}): its manager is a {kind_name} subclass")


def manager_options(own: ManagerSpec | None, manager: str | type) -> dict[str, Any]:
    """The one rule for a scenario's ``[manager] options`` (issue 29 item 9; docs/loop.md, "Which options
    a fleet manager gets"), for ``vcran run``, ``sweep``, ``fuzz``, ``manage`` and :func:`simulate` alike:
    they are keyword arguments of the class the scenario names, so that class gets them however it is
    named (``--manager`` with the same class, or another ``module:Class`` path to the same class object),
    and any other class, a subclass too, gets none, for vcran cannot know which keywords another class
    takes. ``--manager`` used to drop them even for the scenario's own class, while a sweep gave them to
    every class, which then refused them. A class the scenario's own path does not import is another."""
    if own is None or not own.options:
        return {}
    if isinstance(manager, str) and manager == own.path:
        return dict(own.options)
    try:
        same = _import(own.path) is (_import(manager) if isinstance(manager, str) else manager)
    except ManagerError:  # the scenario's class is not there (or the named one, which build_manager says)
        same = False
    return dict(own.options) if same else {}


def _check_attributes(manager: Manager) -> None:
    """``attributes`` names what the robots publish (docs/contract.md §2), or is None. A misspelt name was never
    notified in simulated time, while ``vcran manage`` subscribed with an empty condition and was told
    of every change: one class, two behaviours, and no word of the mistake."""
    from vcran.core.opil.manager import FleetManager
    from vcran.core.opil.messages import OUTBOUND, RENAMED

    if not isinstance(manager, FleetManager):
        return  # a VDA 5050 master lists topics, checked as they are heard
    wanted = manager.attributes
    if wanted is None:
        return
    if (isinstance(wanted, str | bytes) or not isinstance(wanted, Collection)
            or not all(isinstance(a, str) for a in wanted)):
        raise ManagerError(f"fleet manager {_name(type(manager))}: attributes must be a set of attribute names or "
                           f"None, got {'the string ' if isinstance(wanted, str) else ''}{wanted!r}")
    unknown = sorted(a for a in wanted if a not in OUTBOUND)
    if unknown:
        renamed = "".join(f"; {old!r} is now {RENAMED[old]!r} (OPIL's own name)" for old in unknown if old in RENAMED)
        raise ManagerError(f"fleet manager {_name(type(manager))}: attributes names {', '.join(map(repr, unknown))}, "
                           f"which no robot publishes ({', '.join(OUTBOUND)}){renamed}")


def _import(path: str) -> Any:
    module_name, _, attribute = path.partition(":")
    if not module_name or not attribute:
        raise ManagerError(f"fleet manager {path!r}: expected 'module:Class', e.g. 'vcran.managers:Dispatcher'")
    try:
        value: Any = _import_module(module_name)
    except ImportError as exc:
        raise ManagerError(f"fleet manager {path!r}: cannot import {module_name}: {exc}") from None
    except Exception as exc:  # noqa: BLE001 - a SyntaxError or a raise in the user's module: not vcran's bug
        raise ManagerError(f"fleet manager {path!r}: cannot import {module_name}: {_described(exc)}") from None
    for part in attribute.split("."):
        if not hasattr(value, part):
            raise ManagerError(f"fleet manager {path!r}: {value.__name__} has no attribute {part!r}")
        value = getattr(value, part)
    return value


def _import_module(name: str) -> Any:
    """``name`` imported, from the current folder too when it is there and nowhere else, as
    ``python -m vcran`` finds it: the ``vcran`` console script does not put the current folder on
    ``sys.path``, so docs/library.md's ``--manager my_module:FirstIdle`` beside the scenario did not
    import. The folder goes last, so an installed package of the same name still wins."""
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as exc:
        top, here = name.partition(".")[0], os.getcwd()
        if exc.name != top or here in sys.path or not (Path(here, f"{top}.py").is_file() or Path(here, top).is_dir()):
            raise
        sys.path.append(here)
        return importlib.import_module(name)


def _described(exc: BaseException) -> str:
    """``ValueError: ...``: the user's code raised it, and its type says what kind of mistake it was."""
    return f"{type(exc).__name__}: {exc}"


def _name(cls: type) -> str:
    return f"{cls.__module__}:{cls.__qualname__}"
