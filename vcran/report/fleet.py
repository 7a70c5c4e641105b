"""The fleet figure of a closed-loop run (docs/contract.md §9): jobs waiting, jobs done and robots busy over time.

Three step curves from the run's events, each changing only at the instant an event happened:

* **jobs waiting** for a robot: from arrival, and again from the cancellation of the job's latest task,
  until the fleet manager sends a task for it or reports it ended (:func:`vcran.core.jobs.waiting_spans`,
  the same count as the loop property "no robot idles while a job waits");
* **jobs done** (completed, reported by the manager) and **jobs failed**, cumulative;
* **robots busy**: robots not WAITING (a task current), the state bands of the timeline, so the area
  under this curve divided by ``sim_time`` is the fleet utilisation of the KPI table times the fleet size.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

from vcran.core.jobs import waiting_spans
from vcran.report.spans import Happenings, History
from vcran.report.style import DPI, save


class FleetRun(Happenings, Protocol):
    """A run folder's :class:`~vcran.report.folder.Run`, or a ``vcran manage`` folder's
    :class:`~vcran.report.managed.ManagedRun` (robots busy as the manager heard them)."""

    @property
    def scenario(self) -> str: ...
    @property
    def seed(self) -> int: ...


@dataclass(frozen=True, slots=True)
class FleetSeries:
    """Values after every instant at which one changed, from t = 0 to the end of the run."""

    t: tuple[float, ...]
    waiting: tuple[int, ...]
    done: tuple[int, ...]
    failed: tuple[int, ...]
    busy: tuple[int, ...]

    def busy_seconds(self) -> float:
        """The area under the busy curve: robot-seconds with a task current."""
        return sum(b * (t1 - t0) for t0, t1, b in zip(self.t, self.t[1:], self.busy, strict=False))


def fleet_series(run: Happenings, histories: dict[str, History]) -> FleetSeries:
    """The three curves of ``run`` (``histories``: :func:`vcran.report.spans.histories` of it)."""
    end = run.sim_time
    # t -> changes of (waiting, done, failed, busy); every curve starts at t = 0 and reaches the end
    steps: dict[float, list[int]] = {0.0: [0, 0, 0, 0], end: [0, 0, 0, 0]}

    def add(t: float, k: int, d: int) -> None:
        steps.setdefault(t, [0, 0, 0, 0])[k] += d

    for _, a, b in waiting_spans(run.events, end):
        if b > a:
            add(a, 0, 1)
            add(b, 0, -1)
    for e in run.events:
        if e["event"] == "job_completed":
            add(float(e["t"]), 1, 1)
        elif e["event"] == "job_failed":
            add(float(e["t"]), 2, 1)
    for history in histories.values():
        for band in history.bands:
            if band.state != history.idle:  # WAITING; a VDA 5050 vehicle's IDLE (vcran.report.vda5050)
                add(band.start, 3, 1)
                add(band.end, 3, -1)
    times = sorted(steps)
    counts = [0, 0, 0, 0]
    curves: list[list[int]] = [[], [], [], []]
    for t in times:
        for k in range(4):
            counts[k] += steps[t][k]
            curves[k].append(counts[k])
    waiting, done, failed, busy = (tuple(c) for c in curves)
    return FleetSeries(tuple(times), waiting, done, failed, busy)


def draw_fleet(run: FleetRun, series: FleetSeries, path: Path) -> None:
    """Two panels sharing the time axis: jobs waiting and robots busy; jobs done and failed."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(12.0, 6.0), dpi=DPI, layout="constrained")
    top, bottom = fig.subplots(2, 1, sharex=True)
    top.step(series.t, series.busy, where="post", color="#1f77b4", label=f"robots busy (of {len(run.robot_ids)})")
    top.step(series.t, series.waiting, where="post", color="#d62728", label="jobs waiting for a robot")
    top.set_ylabel("count")
    top.set_ylim(0, 1.3 * max(len(run.robot_ids), *series.waiting, 1))  # head room for the legend
    top.legend(loc="upper left", frameon=False, ncol=2)
    bottom.step(series.t, series.done, where="post", color="#2ca02c", label="jobs done")
    if series.failed[-1]:
        bottom.step(series.t, series.failed, where="post", color="#7d3c98", label="jobs failed")
    bottom.set_ylabel("jobs (cumulative)")
    bottom.set_xlabel("simulated time (s)")
    bottom.set_ylim(0, 1.2 * max(series.done[-1] + series.failed[-1], 1))
    bottom.set_xlim(0, max(run.sim_time, 1e-9))
    bottom.legend(loc="upper left", frameon=False)
    for ax in (top, bottom):
        ax.grid(True, axis="y", alpha=0.3)
    fig.suptitle(f"{run.scenario}: the fleet over time ({len(run.robot_ids)} robots, seed {run.seed})")
    save(fig, path)
