"""VDA 5050 properties, checked on a run's output folder (``vcran fuzz`` on a VDA 5050 scenario,
docs/fuzzing.md "VDA 5050 scenarios"; the OPIL twin is :mod:`vcran.testing.checks`).

A perturbed script legitimately gets orders rejected, discarded and cancelled; what must hold is:

* **schema**: every message a vehicle sent (the trace's ``out`` records) validates against the official
  schema of the vehicle's version (§7, docs/contract.md §11);
* **answered**: every order that reached a vehicle got exactly one verdict (accepted, rejected or
  discarded), and one that does not decode was rejected with a ``validationError`` (§6.6.4.1);
* **acceptance**: each decodable order's verdict is the reference model's
  (:class:`~vcran.testing.vda5050.model.ReferenceVehicle`), computed from the last ``state`` the vehicle
  published before it, where that state is certain: when the verdict is the vehicle's first event at its
  instant and no other message reached the vehicle then (at one instant, the order in which a vehicle
  takes simultaneous inputs is the simulation's, not what a master sees);
* **orders end**: every accepted order ends at most once; one still open when the run ended is still
  executing in the vehicle's last state (nodeStates, or an action of it not final), and when the run went
  idle none is open.

They work on a run's trace records and events as plain data; :func:`vcran.testing.vda5050_runs.run_variant`
reads them from a run's folder, and also runs the variant again (byte-identical, docs/contract.md §5) and
replays its trace (docs/contract.md §6); a crash is a violation.
"""

from __future__ import annotations

from collections import defaultdict
from typing import Any

from vcran.core.scenario import Scenario
from vcran.core.vda5050 import codec, validation
from vcran.core.vda5050.config import VehicleConfig
from vcran.core.vda5050.effects import Where
from vcran.core.vda5050.enums import Topic
from vcran.core.vda5050.fleet import vehicle_config
from vcran.core.vda5050.order import Order
from vcran.core.vda5050.outcomes import Ended, Opened, OrderLog
from vcran.core.vda5050.state import State
from vcran.testing.vda5050.model import DISCARD, NEW, UPDATE, ReferenceVehicle

VERDICTS = ("order_accepted", "order_rejected", "order_discarded")
#: The outbound topics and the schema each validates against.
SENT = {t.value: t for t in (Topic.STATE, Topic.FACTSHEET, Topic.CONNECTION, Topic.VISUALIZATION)}


def check_run(records: list[dict[str, Any]], events: list[dict[str, Any]], scenario: Scenario,
              finished: bool) -> list[str]:
    """Every violation of the properties (module docstring) in a run's trace ``records`` and ``events``;
    ``finished``: the run went idle."""
    configs = {r.id: vehicle_config(r, scenario.settings) for r in scenario.robots}
    return (check_schema(records, configs) + check_verdicts(records, events, configs)
            + check_orders_end(records, events, finished))


def check_schema(records: list[dict[str, Any]], configs: dict[str, VehicleConfig]) -> list[str]:
    problems = []
    for r in records:
        topic = SENT.get(r.get("attr", ""))
        if r.get("dir") != "out" or topic is None or r["robot"] not in configs:
            continue
        version = configs[r["robot"]].version
        found = validation.first_problem(validation.outbound(topic, version), r["raw"])
        if found is not None:
            problems.append(f"t={r['t']} {r['robot']}: {topic.value} invalid against VDA 5050 {version.value}'s "
                            f"schema at {found[0]}: {found[1]} (§7)")
    return problems


def check_verdicts(records: list[dict[str, Any]], events: list[dict[str, Any]],
                   configs: dict[str, VehicleConfig]) -> list[str]:
    """*answered* and *acceptance* (module docstring)."""
    verdicts: dict[str, list[dict[str, Any]]] = defaultdict(list)
    first_at: dict[tuple[str, float], dict[str, Any]] = {}
    for e in events:
        first_at.setdefault((e["robot"], e["t"]), e)
        if e["event"] in VERDICTS:
            verdicts[e["robot"]].append(e)
    inbound_at: dict[tuple[str, float], int] = defaultdict(int)
    for r in records:
        if r.get("dir") == "in":
            inbound_at[(r["robot"], r["t"])] += 1
    problems: list[str] = []
    state: dict[str, State] = {}
    instant_ids: dict[str, set[str]] = defaultdict(set)
    answered: dict[str, int] = defaultdict(int)
    for r in records:
        robot, attr = r["robot"], r.get("attr")
        config = configs.get(robot)
        if config is None:
            continue
        if r.get("dir") == "out" and attr == "state":
            decoded = codec.decode(Topic.STATE, r["raw"], config.version)
            if not isinstance(decoded, codec.Invalid):
                state[robot] = decoded
        elif r.get("dir") == "in" and attr == "instantActions":
            decoded = codec.decode(Topic.INSTANT_ACTIONS, r["raw"], config.version)
            if not isinstance(decoded, codec.Invalid):
                instant_ids[robot].update(a.action_id for a in decoded.actions)
        elif r.get("dir") == "in" and attr == "order":
            k = answered[robot]
            answered[robot] += 1
            if k >= len(verdicts[robot]):
                problems.append(f"t={r['t']} {robot}: an order got no verdict (accepted, rejected or discarded)")
                continue
            verdict = verdicts[robot][k]
            order = codec.decode(Topic.ORDER, r["raw"], config.version)
            if isinstance(order, codec.Invalid):
                if _kind(verdict) != "validationError":
                    problems.append(f"t={r['t']} {robot}: an order that does not decode ({order.path}: "
                                    f"{order.problem}) got {_kind(verdict)}, not a validationError (§6.6.4.1)")
                continue
            certain = first_at[(robot, verdict["t"])] is verdict and inbound_at[(robot, r["t"])] == 1
            if certain and robot in state:
                expected = _expected(config, state[robot], order, instant_ids[robot])
                if expected != _kind(verdict):
                    problems.append(f"t={r['t']} {robot}: order {order.order_id} update {order.order_update_id}: "
                                    f"the vehicle's verdict is {_kind(verdict)}, the reference model's {expected} "
                                    "(§6.6.2, Figure 8; §6.6.4)")
    for robot, got in verdicts.items():
        if len(got) > answered[robot]:
            problems.append(f"{robot}: {len(got)} order verdicts for {answered[robot]} orders received")
    return problems


def _expected(config: VehicleConfig, state: State, order: Order, instant_ids: set[str]) -> str:
    position = state.agv_position
    where = Where(position.x, position.y, position.theta) if position is not None else Where(0.0, 0.0, 0.0)
    return ReferenceVehicle(config).order(state, order, where, instant_ids)


def _kind(verdict: dict[str, Any]) -> str:
    """A verdict event as the model names it: new, update, discard, or the refusal's errorType."""
    if verdict["event"] == "order_accepted":
        return UPDATE if verdict.get("update") else NEW
    if verdict["event"] == "order_discarded":
        return DISCARD
    return str((verdict.get("error") or {}).get("errorType"))


def check_orders_end(records: list[dict[str, Any]], events: list[dict[str, Any]], finished: bool) -> list[str]:
    """*orders end* (module docstring)."""
    logs: dict[str, OrderLog] = defaultdict(OrderLog)
    problems = []
    for e in events:
        log = logs[e["robot"]]
        before = log.current
        change = log.feed(e)
        if e["event"] == "order_ended" and not isinstance(change, Ended):
            problems.append(f"t={e['t']} {e['robot']}: order {e.get('order_id')} ended, but no order was open")
        elif isinstance(change, Opened) and before is not None:
            problems.append(f"t={e['t']} {e['robot']}: order {change.order_id} opened over {before}")
    last: dict[str, dict[str, Any]] = {}
    for r in records:
        if r.get("dir") == "out" and r.get("attr") == "state":
            last[r["robot"]] = r["raw"]
    for robot, log in logs.items():
        if log.current is None:
            continue
        if finished:
            problems.append(f"{robot}: order {log.current} never ended, though the run went idle")
            continue
        shown = last.get(robot, {})
        executing = bool(shown.get("nodeStates")) or any(
            a["actionStatus"] not in ("FINISHED", "FAILED") for a in shown.get("actionStates", ()))
        if shown.get("orderId") != log.current or not executing:
            problems.append(f"{robot}: order {log.current} neither ended nor executing in the last state")
    return problems


__all__ = ["check_run", "check_schema", "check_verdicts", "check_orders_end"]
