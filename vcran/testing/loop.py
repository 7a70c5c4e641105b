"""Fuzzing a fleet manager in the loop (docs/contract.md §9): workload and link strategies, and the properties a
user applies to their own manager. docs/fuzzing.md ("Fuzzing your fleet manager") shows them in a test.

Strategies draw what a fleet manager meets in a warehouse it does not control:

* :func:`job_lists` — jobs at random times between random stations (shrinks to fewer, earlier jobs);
* :func:`stocks` — how many parts each pickup station holds at the start (an empty line makes a load
  fail, and its task is cancelled with ``action_failed``: the manager must re-plan or give up);
* :func:`links` — the link's latency, seeded jitter, and loss: under ``polling`` a write overwritten
  before the RAN reads it is lost, as with Orion (docs/contract.md §7); a VDA 5050 fleet's broker loses
  messages outright (``loss``, MQTT's QoS 0, §6.2);
* :func:`fault_lists` — docs/contract.md §4 faults at random times: breakdowns, motion and action failures,
  ``link_down`` (shrinks to none);
* :func:`loop_variants` — all four applied to a base scenario, as a :class:`~vcran.core.scenario.Scenario`.

The properties read a :class:`vcran.Result` and return human-readable violations (an empty list when
the manager behaved); :func:`assert_loop_properties` raises one AssertionError listing them all:

* :func:`check_jobs_ended` — every job ended: completed, or reported failed (none left open);
* :func:`~vcran.testing.outcomes.check_failures_have_evidence` — a job is reported failed only with
  evidence: a task sent for it ended without success, or no robot could serve it;
* :func:`~vcran.testing.outcomes.check_feasible_jobs_completed` — without faults, a feasible workload
  completes every job by the run's end (``margin``);
* :func:`check_protocol` — the manager caused no ``ran_error`` of a protocol kind (:data:`PROTOCOL_ERRORS`:
  the R2/R8-R10/R12 rejections; action failures and cancel races are not the manager's protocol bugs);
* :func:`check_no_idle_while_waiting` — no robot sat idle (WAITING) for more than ``bound`` seconds
  while a job was waiting for a robot. A job waits from its arrival, and again from the cancellation of
  its latest task, until the manager sends a task for it or reports it ended;
* :func:`~vcran.testing.deadlocks.check_no_deadlock` — where it applies (a roadmap, or ``deadlock``
  events: docs/contract.md §12): no ``deadlock`` event, and no robot stuck idle on an open job past a bound.

:func:`fuzz_manager` is the search behind ``vcran fuzz SCENARIO --manager module:Class``: hypothesis's
``find`` over :func:`loop_variants`, seeded, without an example database, shrinking to a minimal failing
scenario that :func:`vcran.io.scenario_toml.loop_toml` writes back as a file ``vcran run`` re-runs.
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

from vcran.testing._extra import require_hypothesis

require_hypothesis(__name__)

from hypothesis import strategies as st

from vcran.core.faults import KINDS, RANDOM_KINDS, FaultSpec
from vcran.core.jobs import waiting_spans
from vcran.core.scenario import POLLING, SUBSCRIPTION, VDA5050, Job, LinkSettings, Scenario
from vcran.testing.deadlocks import STUCK_BOUND, check_no_deadlock
from vcran.testing.deadlocks import applies as deadlock_applies
from vcran.testing.outcomes import COMPLETION_MARGIN, check_failures_have_evidence, check_feasible_jobs_completed
from vcran.testing.spans import assignees, away_spans, fault_spans, idle_spans, minus, robot_at

#: ``ran_error`` codes that mean the fleet manager broke the OPIL protocol (docs/rules.md).
PROTOCOL_ERRORS = frozenset({
    "length_mismatch", "position_taken", "kind_order", "task_completed", "task_cancelled", "already_dispatched",
    "position_changed", "assignment_cancelled", "malformed", "outside_motion_area", "unknown_robot",
})

#: Default for :func:`check_no_idle_while_waiting`: a robot may idle this long while a job waits.
IDLE_BOUND = 60.0


# --- strategies -------------------------------------------------------------------------------------------


def workload_stations(scenario: Scenario) -> tuple[list[str], list[str]]:
    """The pickup and drop-off stations a workload may use: those of the scenario's own workload (its
    stream's choices and listed jobs), else every station for both."""
    pickups: list[str] = []
    dropoffs: list[str] = []
    if scenario.job_stream is not None:
        pickups += [p for p, _ in scenario.job_stream.pickups]
        dropoffs += [d for d, _ in scenario.job_stream.dropoffs]
    pickups += [j.pickup for j in scenario.jobs]
    dropoffs += [j.dropoff for j in scenario.jobs]
    if not pickups:
        pickups = dropoffs = [s.id for s in scenario.stations]
    return list(dict.fromkeys(pickups)), list(dict.fromkeys(dropoffs))


@st.composite
def job_lists(draw: st.DrawFn, pickups: Sequence[str], dropoffs: Sequence[str], *, max_jobs: int = 8,
              horizon: float = 300.0) -> list[Job]:
    """1..``max_jobs`` jobs arriving in ``[0, horizon]``, each from a pickup to a different drop-off,
    named ``job_1``, ``job_2``, ... in arrival order."""
    if max_jobs < 1:
        raise ValueError(f"max_jobs must be at least 1, got {max_jobs}")
    tenths = _tenths_within(horizon)
    pairs = [(p, d) for p in pickups for d in dropoffs if p != d]
    if not pairs:
        raise ValueError("no pickup/drop-off pair of two different stations")
    drawn = draw(st.lists(st.tuples(tenths, st.sampled_from(pairs)), min_size=1, max_size=max_jobs))
    drawn.sort(key=lambda item: item[0])
    return [Job(t, f"job_{n}", p, d) for n, (t, (p, d)) in enumerate(drawn, start=1)]


def stocks(pickups: Sequence[str], max_parts: int = 10) -> st.SearchStrategy[dict[str, int]]:
    """Parts held at the start by each pickup station (shrinks towards empty stations)."""
    return st.fixed_dictionaries({p: st.integers(0, max_parts) for p in pickups})


#: Latencies and jitters drawn by :func:`links`, the default first: from a LAN to a slow, loaded Orion.
LATENCIES = (0.05, 0.001, 0.01, 0.2, 0.5, 1.0, 2.0)
JITTERS = (0.0, 0.01, 0.1, 0.5, 1.0)
#: Message losses drawn for a broker's link (a VDA 5050 fleet's, MQTT's QoS 0): none first, up to one in ten.
LOSSES = (0.0, 0.01, 0.02, 0.05, 0.1)


def links(latencies: Sequence[float] = LATENCIES, jitters: Sequence[float] = JITTERS,
          inbounds: Sequence[str] = (SUBSCRIPTION, POLLING), losses: Sequence[float] = (0.0,),
          ) -> st.SearchStrategy[LinkSettings]:
    """Link settings: latency, seeded jitter, subscription or (lossy) polling semantics, and message loss.
    Values come from short lists, so a failure shrinks in a few steps towards the defaults (50 ms, no
    jitter, subscription, no loss). A VDA 5050 fleet's link is a broker's: ``inbounds=(SUBSCRIPTION,)``
    (polling is OPIL's) and ``losses=LOSSES`` (Orion's link loses nothing: an OPIL scenario refuses loss)."""
    return st.builds(
        LinkSettings,
        latency=st.sampled_from(latencies),
        jitter=st.sampled_from(jitters),
        inbound=st.sampled_from(list(inbounds)),
        poll_interval=st.sampled_from([0.25, 0.1, 1.0]),
        loss=st.sampled_from(list(losses)),
    )


#: Durations of breakdowns and link outages drawn by :func:`fault_lists` (short, medium, most of
#: :data:`IDLE_BOUND`); :func:`check_no_idle_while_waiting` does not count them as idle time.
FAULT_DURATIONS = (5.0, 20.0, 45.0)


def _tenths_within(horizon: float) -> st.SearchStrategy[float]:
    """Instants in ``[0, horizon]`` at tenths of a second, drawn as integers (they shrink in few steps)."""
    if not (math.isfinite(horizon) and horizon >= 0):  # int(inf * 10) overflowed; a negative one has nothing
        raise ValueError(f"horizon must be a finite number of seconds >= 0, got {horizon}")
    if not math.isfinite(horizon * 10):  # finite, but int(horizon * 10) overflows as inf did
        raise ValueError(f"horizon {horizon:g} s is too large: instants are drawn at tenths of a second up to it")
    return st.integers(0, int(horizon * 10)).map(lambda k: k / 10)


@st.composite
def fault_lists(draw: st.DrawFn, robots: Sequence[str], *, max_faults: int = 4, horizon: float = 300.0,
                kinds: Sequence[str] = RANDOM_KINDS, durations: Sequence[float] = FAULT_DURATIONS) -> list[FaultSpec]:
    """0..``max_faults`` faults (docs/contract.md §4) in ``[0, horizon]``, in time order. ``kinds`` defaults to what
    breaks without an operator (breakdown, motion_failure, action_failure, link_down; a pause without its
    resume would hold a robot for good, which no manager can mend). Shrinks towards no fault."""
    if max_faults < 0:
        raise ValueError(f"max_faults must be at least 0, got {max_faults}")
    tenths = _tenths_within(horizon)
    drawn = draw(st.lists(st.tuples(tenths, st.sampled_from(list(robots)), st.sampled_from(list(kinds)),
                                    st.sampled_from(list(durations))), max_size=max_faults))
    drawn.sort(key=lambda item: item[0])
    return [FaultSpec(t, robot, kind, duration if KINDS[kind] else 0.0) for t, robot, kind, duration in drawn]


@st.composite
def loop_variants(draw: st.DrawFn, base: Scenario, *, max_jobs: int = 8, horizon: float = 300.0,
                  settle: float = 600.0, vary_link: bool = True, vary_stock: bool = True,
                  max_faults: int = 4) -> Scenario:
    """``base`` with a drawn workload (listed jobs; its stream dropped), station stock, link and up to
    ``max_faults`` faults (added to ``base``'s own; 0: none drawn). The run lasts ``horizon + settle``
    simulated seconds at most and ends early once idle; ``base``'s faults after that end, and its random
    fault sources that would start after it, are dropped (they would never happen)."""
    if not isinstance(base, Scenario):  # vcran.simulate takes a path; this needs the scenario to vary
        raise TypeError(f"loop_variants: base must be a vcran.Scenario (vcran.load_scenario(path)), got "
                        f"{type(base).__name__} {base!r}")
    if not (math.isfinite(settle) and settle >= 0):  # nan made the run's duration nan, -1 ended it before the jobs
        raise ValueError(f"settle must be a finite number of seconds >= 0, got {settle}")
    if max_faults < 0:  # as fault_lists refuses it, rather than read as "none"
        raise ValueError(f"max_faults must be at least 0, got {max_faults}")
    pickups, dropoffs = workload_stations(base)
    if base.settings.duration is not None:  # a job or fault after the end never happens: it fails to load
        horizon = min(horizon, base.settings.duration)  # (docs/scenarios.md), so a saved failure would too
    jobs = draw(job_lists(pickups, dropoffs, max_jobs=max_jobs, horizon=horizon))
    stations = base.stations
    if vary_stock:
        stock = draw(stocks(sorted({j.pickup for j in jobs})))
        stations = tuple(replace(s, parts=stock[s.id]) if s.id in stock else s for s in stations)
    broker = base.settings.protocol == VDA5050  # MQTT has no polling (docs/vda5050.md, "In the closed loop")
    link = (draw(links(inbounds=(SUBSCRIPTION,), losses=LOSSES) if broker else links()) if vary_link
            else base.link)
    duration = horizon + settle
    if base.settings.duration is not None:
        duration = min(duration, base.settings.duration)
    # base's faults after the variant's end never happen: dropped, as the loader refuses them
    faults = tuple(f for f in base.faults if f.t <= duration)
    random_faults = tuple(source for source in base.random_faults if source.start < duration)
    if max_faults > 0:
        drawn = draw(fault_lists([r.id for r in base.robots], max_faults=max_faults, horizon=horizon))
        faults = tuple(sorted(faults + tuple(drawn), key=lambda f: f.t))  # stable: base's first at ties
    settings = replace(base.settings, duration=duration, until_idle=True)
    return replace(base, settings=settings, stations=stations, jobs=tuple(jobs), job_stream=None, link=link,
                   faults=faults, random_faults=random_faults)


# --- properties -------------------------------------------------------------------------------------------


def check_jobs_ended(result: Any) -> list[str]:
    """Every job that reached the manager ended: completed, or reported failed."""
    return [f"job {r.id} (arrived t={r.job.t:g}, {r.job.pickup} -> {r.job.dropoff}) never ended: neither "
            f"completed nor reported failed by t={result.summary['sim_time']:g} ({len(r.tasks)} task(s) sent)"
            for r in result.jobs if r.outcome == "open"]


def check_protocol(result: Any) -> list[str]:
    """No ``ran_error`` of a protocol kind (:data:`PROTOCOL_ERRORS`): the manager spoke OPIL correctly; a VDA 5050
    master, no order its vehicle refused (``order_rejected``: invalid, a stale update, an order the vehicle
    could not take, §6.6.4).

    Rejections of a robot while its link is down, up to the instant it is back (docs/contract.md §4), are the outage's: what
    the manager wrote meanwhile was held and is judged against a world that moved on (a task timed out). A VDA 5050
    vehicle's ``orderError`` while it is broken down (not in running condition, §6.6.4) is the breakdown's: the
    master learns of the FATAL error from a state, which may still be on its way, or lost (QoS 0, §6.2).
    """
    end = float(result.summary["sim_time"])
    cut_off = fault_spans(result.events, end, frozenset({"link_down"}))
    broken = fault_spans(result.events, end, frozenset({"breakdown"}))
    return [_protocol_error(e) for e in result.events
            if ((e["event"] == "rejected" and e.get("code") in PROTOCOL_ERRORS) or e["event"] == "order_rejected")
            and not any(a <= e["t"] <= b for a, b in cut_off.get(e["robot"], []))
            and not (e["event"] == "order_rejected" and _not_running(e.get("error") or {})
                     and any(a <= e["t"] <= b for a, b in broken.get(e["robot"], [])))]


def _not_running(error: dict[str, Any]) -> bool:
    """The refusal of an order by a vehicle with a FATAL error (vcran.core.vda5050.acceptance, §6.6.4)."""
    return error.get("errorType") == "orderError" and str(error.get("errorDescription", "")).startswith(
        "the vehicle is not in running condition")


def _protocol_error(e: dict[str, Any]) -> str:
    if e["event"] == "rejected":
        return f"t={e['t']:g} {e['robot'] or 'fleet'}: ran_error {e['code']}: {e.get('message', '')}"
    error = e.get("error") or {}
    return (f"t={e['t']:g} {e['robot']}: order {e.get('order_id')} (update {e.get('order_update_id')}) refused, "
            f"{error.get('errorType')}: {error.get('errorDescription', '')}")


def check_no_idle_while_waiting(result: Any, bound: float = IDLE_BOUND) -> list[str]:
    """No robot idle (WAITING) for more than ``bound`` seconds at a stretch while a job waited.

    Judged by what the manager could know (docs/contract.md §4): a robot out of its reach (link down) or broken down is
    not idle, nor is one out of service (its battery empty, until swapped), and a job whose task was
    cancelled on a robot whose link was down waits, for the manager, only from when that link is back.
    Such spans cut the stretches rather than lengthen them. A robot that cannot move parts (not configured
    to load and unload; known from ``result.scenario`` when the result has one) is never idle for a job.
    """
    if not bound >= 0:  # a negative bound reported every robot, over stretches that end before they begin
        raise ValueError(f"check_no_idle_while_waiting: bound must be a number of seconds >= 0, got {bound}")
    end = float(result.summary["sim_time"])
    away = away_spans(result.events, end)
    unseen = fault_spans(result.events, end, frozenset({"link_down"}))
    given = assignees(result.events)
    waiting = [(job, c, d) for job, a, b in waiting_spans(result.events, end)
               for c, d in minus([(a, b)], unseen.get(robot_at(given.get(job, []), a), []))]
    problems = []
    scenario = getattr(result, "scenario", None)
    robots = [r.id for r in scenario.robots if r.moves_parts] if isinstance(scenario, Scenario) else result.robots
    for robot, idle in idle_spans(result.events, robots, end).items():
        for a, b in minus(idle, away.get(robot, [])):
            for job, c, d in waiting:
                lo, hi = max(a, c), min(b, d)
                if hi - lo > bound:
                    problems.append(f"{robot} idle from t={lo:g} to t={hi:g} ({hi - lo:g} s > {bound:g} s) "
                                    f"while job {job} waited (since t={c:g})")
                    break
    return problems


def loop_problems(result: Any, bound: float = IDLE_BOUND, margin: float = COMPLETION_MARGIN,
                  stuck: float = STUCK_BOUND) -> list[str]:
    """Every violation of the five properties, and of "no deadlock" where it applies
    (:func:`vcran.testing.deadlocks.applies`; ``stuck``: its bound)."""
    return (check_jobs_ended(result) + check_failures_have_evidence(result)
            + check_feasible_jobs_completed(result, margin) + check_protocol(result)
            + check_no_idle_while_waiting(result, bound)
            + (check_no_deadlock(result, stuck) if deadlock_applies(result) else []))


def assert_loop_properties(result: Any, bound: float = IDLE_BOUND, margin: float = COMPLETION_MARGIN,
                           stuck: float = STUCK_BOUND) -> None:
    """Raise AssertionError listing every violation of the loop properties (:func:`loop_problems`)."""
    problems = loop_problems(result, bound, margin, stuck)
    if problems:
        raise AssertionError("the fleet manager broke the loop properties:\n  " + "\n  ".join(problems))


# --- the search -------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Finding:
    """A minimal failing scenario, the violations it shows, and how long the search took."""

    scenario: Scenario
    problems: list[str]
    examples: int
    shrinks: int


def run_problems(scenario: Scenario, manager: Any, bound: float = IDLE_BOUND) -> list[str]:
    """Run ``scenario`` in memory with a fresh ``manager`` (anything :func:`vcran.simulate` takes; an
    instance is reused, so pass a class or ``"module:Class"``) and return the loop's violations. An
    exception the manager raises is a violation too."""
    from vcran.api import ManagerError, simulate

    try:
        result = simulate(scenario, manager=manager)
    except ManagerError:
        raise
    except Exception as exc:  # noqa: BLE001 - the manager's crash is the finding
        notes = "; ".join(getattr(exc, "__notes__", []))
        return [f"crash: {type(exc).__name__}: {exc}" + (f" ({notes})" if notes else "")]
    return loop_problems(result, bound)


def fuzz_manager(base: Scenario, manager: Any, *, examples: int = 50, seed: int = 0, bound: float = IDLE_BOUND,
                 max_jobs: int = 8, horizon: float = 300.0, settle: float = 600.0, max_faults: int = 4,
                 on_example: Callable[[], None] | None = None) -> Finding | None:
    """Search for a workload, stock, link and faults (up to ``max_faults``; 0: none) under which ``manager``
    breaks a loop property; None when ``examples`` variants ran clean. One ``seed``, one sequence of
    examples and one shrunk result."""
    from hypothesis import HealthCheck, Phase, find, settings
    from hypothesis.errors import NoSuchExample

    counts = {"examples": 0, "shrinks": 0}
    found = False

    def violated(variant: Scenario) -> bool:
        nonlocal found
        counts["shrinks" if found else "examples"] += 1
        if on_example is not None:
            on_example()
        bad = bool(run_problems(variant, manager, bound))
        found = found or bad
        return bad

    strategy = loop_variants(base, max_jobs=max_jobs, horizon=horizon, settle=settle, max_faults=max_faults)
    options = settings(max_examples=examples, database=None, deadline=None, suppress_health_check=list(HealthCheck),
                       phases=[Phase.generate, Phase.shrink])
    try:
        minimal = find(strategy, violated, settings=options, random=random.Random(seed))
    except NoSuchExample:
        return None
    return Finding(minimal, run_problems(minimal, manager, bound), counts["examples"], counts["shrinks"])
