"""Key figures per robot and for the fleet: what got done, what was lost and why, how busy the robots were.

Counts, shares and latencies come from the events (through :mod:`vcran.report.spans`), distance, parts
moved and errors from the summary, which the model computed exactly (distance from the leg kinematics,
not from the 1 s telemetry samples). docs/report.md defines every column.
"""

from __future__ import annotations

from dataclasses import dataclass

from vcran.report.folder import Run
from vcran.report.incidents import downtime
from vcran.report.spans import REASONS, History
from vcran.report.traffic import blocking, fleet_deadlocks

FLEET = "fleet"


@dataclass(frozen=True, slots=True)
class Kpi:
    """One row of the KPI table: a robot, or the fleet (``robot == "fleet"``)."""

    robot: str
    completed: int
    cancelled: dict[str, int]
    distance: float
    busy_share: float
    latency: float | None
    parts_moved: int
    errors: int
    #: docs/contract.md §4: charge drawn per completed task (Ah; None without a battery or a completed task),
    #: seconds held or out of service, collisions.
    energy_per_job: float | None = None
    downtime: float = 0.0
    collisions: int = 0
    #: docs/contract.md §12, with safety fields (else None): blocks, seconds blocked, deadlocks (vcran.report.traffic).
    blocks: int | None = None
    blocked_time: float | None = None
    deadlocks: int | None = None
    #: VDA 5050 (orders are the unit of work, docs/report.md): orders the vehicle refused; None for OPIL.
    rejected: int | None = None

    @property
    def idle_share(self) -> float:
        return 1.0 - self.busy_share


def kpis(run: Run, histories: dict[str, History]) -> list[Kpi]:
    """One row per robot in fleet order, then the fleet row.

    Busy share is time not WAITING over the run's simulated time. The fleet's busy share is the fleet's
    busy robot-seconds over all robot-seconds (the mean of the robots' shares), and its latency the mean
    over every completed task, so a robot with many tasks weighs more than one with few. The fleet's
    errors are the run's total, which includes inputs for entities no robot owns (R11). With safety fields
    (docs/contract.md §12) the fleet's blocks and blocked time are the robots' sums, its deadlocks the ``deadlock``
    events (a cycle of robots counts once).
    """
    rows = []
    all_latencies: list[float] = []
    busy_total = 0.0
    down = downtime(run)
    traffic = blocking(run) if run.fields else None
    vda = run.protocol == "vda5050"
    for rid, history in histories.items():
        latencies = [s.end - s.queued for s in history.tasks if s.completed]
        all_latencies += latencies
        busy_total += history.busy
        result = run.results[rid]
        rows.append(Kpi(
            robot=rid,
            completed=len(latencies),
            cancelled={r: sum(s.outcome == r for s in history.tasks) for r in REASONS},
            distance=result.distance,
            busy_share=_share(history.busy, run.sim_time),
            latency=_mean(latencies),
            parts_moved=result.parts_moved,
            errors=result.errors,
            energy_per_job=_per(result.energy_used, len(latencies)),
            downtime=down[rid],
            collisions=result.collisions,
            rejected=history.rejected if vda else None,
            **({} if traffic is None else {"blocks": traffic[rid].blocks, "blocked_time": traffic[rid].blocked_time,
                                           "deadlocks": traffic[rid].deadlocks}),
        ))
    used = [run.results[rid].energy_used for rid in histories]
    rows.append(Kpi(
        robot=FLEET,
        completed=sum(r.completed for r in rows),
        cancelled={reason: sum(r.cancelled[reason] for r in rows) for reason in REASONS},
        distance=sum(r.distance for r in rows),
        busy_share=_share(busy_total, run.sim_time * len(histories)),
        latency=_mean(all_latencies),
        parts_moved=sum(r.parts_moved for r in rows),
        errors=run.errors,
        energy_per_job=_per(sum(u for u in used if u is not None) if any(u is not None for u in used) else None,
                            sum(r.completed for r in rows)),
        downtime=sum(r.downtime for r in rows),
        collisions=sum(r.collisions for r in rows) // 2,  # each collision involves two robots
        rejected=sum(h.rejected for h in histories.values()) if vda else None,
        **({} if traffic is None else {"blocks": sum(b.blocks for b in traffic.values()),
                                       "blocked_time": sum(b.blocked_time for b in traffic.values()),
                                       "deadlocks": fleet_deadlocks(run)}),
    ))
    return rows


def _per(total: float | None, jobs: int) -> float | None:
    return total / jobs if total is not None and jobs else None


def _share(part: float, whole: float) -> float:
    return part / whole if whole > 0 else 0.0


def _mean(values: list[float]) -> float | None:
    return sum(values) / len(values) if values else None
