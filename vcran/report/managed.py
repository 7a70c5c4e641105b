"""The report of a ``vcran manage --out`` folder: the fleet manager's side of a live run (issue 29 item 12).

``vcran manage`` runs a fleet manager against Orion next to ``vcran live`` (or a real fleet), so its
folder holds what the manager knew, not what the robots did: the ``job_*`` events, the robots' states and
task ends as the manager heard them through Orion (``state``, ``task_completed``, ``task_cancelled``,
logged by :class:`transports.orion.manage.OrionLoop` when each ``ran_status`` reached it), and a summary
with the ``jobs`` KPIs, the fleet's robot ids, the manager and the seed. No trace, no telemetry.

A ``vcran manage --mqtt`` folder (a VDA 5050 master; its summary says ``"protocol": "vda5050"``) holds, besides
the ``job_*`` events, the vehicles' orders as the master heard them in their states (``order_accepted``,
``order_ended``, logged by :class:`transports.mqtt.manage.MqttLoop`, :mod:`vcran.core.vda5050.heard`): a
vehicle is busy from an order heard accepted to its heard end, as a simulated VDA 5050 run's vehicle is
from its order's acceptance to its end (:mod:`vcran.report.vda5050`).

From it a report draws what it can: the fleet figure (jobs waiting for a robot, jobs done and failed,
robots busy as heard: :mod:`vcran.report.fleet`, the same curves as a simulated closed loop's) and
``kpi.md`` with the jobs table, whose utilisation is the heard busy time's share. The layout, the
timeline and the per-robot KPIs need the robots' own record, the ``vcran live --out`` folder, which
``vcran report`` reads as any run folder; ``kpi.md`` and the command say so.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vcran.io.trace import EVENTS_FILE
from vcran.report.folder import JobFigures, ReportError, checked_events, job_figures, reading
from vcran.report.spans import histories

SUMMARY = "summary.json"
#: What a managed folder's report leaves out, and where it is (printed, and in kpi.md).
NOT_HERE = ("the layout, the timeline and the robots' KPIs are not in a `vcran manage` folder (the manager "
            "does not see them): report the `vcran live --out` folder for those")


@dataclass(frozen=True)
class ManagedRun:
    """A ``vcran manage --out`` folder read back: what the fleet figure needs (a :class:`Run`'s
    ``scenario``, ``seed``, ``sim_time``, ``events``, ``robot_ids``), the manager, and the jobs."""

    path: Path
    scenario: str
    #: The scenario's protocol: ``opil`` (``--orion``) or ``vda5050`` (``--mqtt``); ``opil`` for a folder that
    #: does not say (written before VDA 5050 masters ran live).
    protocol: str
    manager: str
    seed: int
    sim_time: float
    robot_ids: tuple[str, ...]
    events: list[dict[str, Any]]
    jobs: JobFigures


def is_managed(path: Path) -> bool:
    """A folder whose summary names a fleet manager and no robots' results: ``vcran manage``'s."""
    try:
        summary = json.loads((path / SUMMARY).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False  # read_run says what is wrong with it
    return isinstance(summary, dict) and "manager" in summary and "robots" not in summary


def read_managed(path: Path) -> ManagedRun:
    """Read and check a ``vcran manage --out`` folder; :class:`ReportError` names what is wrong."""
    if not (path / EVENTS_FILE).is_file():
        raise ReportError(f"{path}: not a complete `vcran manage` folder, missing {EVENTS_FILE}")
    with reading(path / SUMMARY):
        summary = json.loads((path / SUMMARY).read_text(encoding="utf-8"))
        if "fleet" not in summary:
            raise ReportError(f"{path / SUMMARY}: a `vcran manage` summary without 'fleet' (the robots' ids), "
                              "written before vcran reported managed runs: run `vcran manage --out` again")
        robots = tuple(str(r) for r in summary["fleet"])
        sim_time = float(summary["sim_time"])
        protocol = str(summary.get("protocol", "opil"))
        events = list(checked_events(path / EVENTS_FILE))
        busy = sum(h.busy for h in histories(_Heard(protocol, robots, events, sim_time)).values())
        share = busy / (sim_time * len(robots)) if sim_time > 0 and robots else 0.0
        jobs = job_figures({"jobs": summary["jobs"], "utilisation": {"fleet": share}})
        return ManagedRun(path, str(summary.get("scenario", "")), protocol, str(summary["manager"]),
                          int(summary.get("seed", 0)), sim_time, robots, events, jobs)


@dataclass(frozen=True)
class _Heard:
    protocol: str
    robot_ids: tuple[str, ...]
    events: list[dict[str, Any]]
    sim_time: float


def write_managed(run: ManagedRun, out: Path, fmt: str) -> tuple[list[Path], str]:
    """``fleet.FMT`` and ``kpi.md`` into ``out``; the files, and the note of what is not drawn."""
    from vcran.report.fleet import draw_fleet, fleet_series
    from vcran.report.tables import jobs_markdown

    out.mkdir(parents=True, exist_ok=True)
    files = [out / f"fleet.{fmt}", out / "kpi.md"]
    draw_fleet(run, fleet_series(run, histories(run)), files[0])
    heard = (("VDA 5050 master", "an MQTT broker's vehicles (`vcran manage --mqtt`)",
              "The vehicles' orders are as the master heard them in their states", "the link's latency")
             if run.protocol == "vda5050" else
             ("fleet manager", "Orion (`vcran manage`)", "Robot states and task ends are as the manager heard "
              "them through Orion", "the notification delay"))
    files[1].write_text(
        f"# KPIs: {run.scenario}\n\nThe {heard[0]} {run.manager} against {heard[1]}, {run.sim_time:g} s, "
        f"{len(run.robot_ids)} robot(s), seed {run.seed}. {heard[2]}, so busy time and utilisation lag the robots "
        f"by {heard[3]}. Columns are defined in vcran's docs/report.md.\n\n## Jobs\n\n{jobs_markdown(run.jobs)}\n"
        f"{NOT_HERE[0].upper()}{NOT_HERE[1:]}.\n",
        encoding="utf-8")
    return files, NOT_HERE
