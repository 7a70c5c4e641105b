"""OPIL's part of a run (docs/protocols.md): a RanLogic per robot around its body, the RAN, OPIL's events.

:class:`Opil` is what :mod:`vcran.sim.protocols` hands the shared :class:`~vcran.sim.model.Model` for the
protocol ``opil`` (:class:`~vcran.sim.protocols.Glue`): it gives each body a :class:`~vcran.sim.opil.node.RanNode`,
routes the transport's messages and publishes the fleet's state through the :class:`~vcran.sim.opil.ran.Ran`,
and keeps the model's books from RanLogic's events (tasks completed and cancelled, the time each robot was not
WAITING).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from vcran.core.events import Event
from vcran.core.opil.effects import ErrorReport, State, StateChanged, TaskCancelled, TaskCompleted
from vcran.core.opil.messages import BatteryState, Header, Message, Time
from vcran.core.opil.motion_area import motion_area_problem
from vcran.core.opil.ranlogic import RanLogic
from vcran.core.wire import Inbound, Transport
from vcran.sim.body import Body
from vcran.sim.opil.node import RanNode
from vcran.sim.opil.ran import Ran
from vcran.sim.opil.traffic import OpilTraffic

if TYPE_CHECKING:
    from vcran.sim.model import Model
    from vcran.sim.power import Level


def default_decode(attribute: str, raw: Any) -> Message:
    from vcran.core.opil.codec import decode_attribute  # imported on first raw payload only

    return decode_attribute(attribute, raw)


class Opil:
    """OPIL's glue for one run of ``model`` (module docstring)."""

    def __init__(self, model: Model) -> None:
        self.model = model
        self.env, self.events = model.env, model.events
        # The model's books, which RanLogic's events keep (:meth:`log`, nine calls a task).
        self._busy_seconds, self._busy_since = model.busy_seconds, model.busy_since
        self._completed, self._cancelled = model.completed, model.cancelled
        self.nodes: list[RanNode] = []
        self.ran: Ran | None = None
        self._settings = model.scenario.settings

    def attach(self, body: Body) -> None:
        """RanLogic and its process for ``body``, before the body's own processes start."""
        s = self._settings
        logic = RanLogic(body.id, task_timeout=s.task_timeout, history_limit=s.history_limit,
                         area_check=motion_area_problem)
        self.nodes.append(RanNode(body, logic, self.log, self.changed))

    def connect(self, transport: Transport) -> None:
        """The RAN between the robots and ``transport`` (nothing is scheduled yet)."""
        self.ran = Ran(self.env, self.nodes, transport, default_decode, self._unknown_entity)

    def start(self, telemetry_period: float, description_period: float, after_tick: Callable[[], bool]) -> None:
        """The RAN's periodic publications: telemetry (then ``after_tick``, which says whether the run is
        over), robot descriptions."""
        assert self.ran is not None
        self.env.process(self.ran.telemetry(telemetry_period, after_tick))
        self.env.process(self.ran.descriptions(description_period))

    # --- what the model asks ----------------------------------------------------------------------------

    @property
    def deliver(self) -> Callable[[Inbound], None]:
        assert self.ran is not None
        return self.ran.deliver

    def every_tick(self, then: Callable[[float], None]) -> None:
        """Call ``then`` with the tick's time after each telemetry tick's statuses (the battery's tick)."""
        assert self.ran is not None
        self.ran.after_statuses = then

    def link_down(self, body: Body, duration: float) -> None:
        assert self.ran is not None
        self.ran.link_down(body, duration)

    @property
    def links_down(self) -> bool:
        return self.ran is not None and self.ran.links_down

    def idle(self) -> bool:
        return all(node.logic.idle for node in self.nodes)

    def errors(self, index: int) -> int:
        return self.nodes[index].logic.error_count

    def traffic(self) -> OpilTraffic:
        """docs/contract.md §12: a blocked robot publishes a ``ran_error`` warning; a deadlock cancel halts it."""
        return OpilTraffic(self.model.robots)

    def battery_states(self, t: float, levels: list[Level]) -> None:
        """``battery_state`` (a ``sensor_msgs.BatteryState``) of each robot whose level changed (docs/contract.md §4)."""
        assert self.ran is not None
        header = Header(0, Time.from_seconds(t), "")
        publish = self.ran.publish
        for body, pct, charge, capacity, level, charging, voltage in levels:
            status = (BatteryState.STATUS_FULL if level >= capacity else
                      BatteryState.STATUS_CHARGING if charging else BatteryState.STATUS_DISCHARGING)
            publish(t, body, "battery_state", BatteryState(
                header=header, voltage=voltage, charge=charge, capacity=capacity, design_capacity=capacity,
                percentage=pct, power_supply_status=status, present=True,
            ))

    # --- RanLogic's events ------------------------------------------------------------------------------

    def log(self, robot: Body, event: Event) -> None:
        now = self.env.now
        if event.NAME:  # else a ran_error whose incident was logged on its own
            self.events.write(now, robot.id, event.NAME, event.fields())
        # By exact class where no subclass exists: nine events a task, most of which matched none of four
        # isinstance calls (issue 30).
        kind = type(event)
        if kind is StateChanged:
            if event.from_ is State.WAITING:  # type: ignore[attr-defined]
                self._busy_since[robot.index] = now
            elif event.to is State.WAITING:  # type: ignore[attr-defined]
                self._busy_seconds[robot.index] += now - (self._busy_since[robot.index] or 0.0)
                self._busy_since[robot.index] = None
        elif kind is TaskCompleted:
            task = event.task  # type: ignore[attr-defined]
            self._completed[robot.id].append(task.description or task.label)  # Event: the label without its call
            self.model.tasks_done += 1
        elif kind is TaskCancelled:
            self._cancelled[robot.id].append(event.task.label, event.reason.value)  # type: ignore[attr-defined]
        elif isinstance(event, ErrorReport):
            assert self.ran is not None
            self.ran.publish_error(robot, event)

    def changed(self, robot: Body) -> None:
        self.ran.changed(robot)  # type: ignore[union-attr]  # connected before anything runs

    def _unknown_entity(self, inbound: Inbound) -> None:
        """R11: an entity no RanLogic owns is reported and dropped."""
        model = self.model
        model.fleet_errors += 1
        known = ", ".join(r.id for r in model.robots[:5]) + (", ..." if len(model.robots) > 5 else "")
        self.events.write(self.env.now, inbound.entity, "rejected", {
            "code": "unknown_robot", "severity": "error",
            "message": f"{inbound.attribute} for entity {inbound.entity}, which no RanLogic owns; robots: {known} [R11]",
        })


def glue(model: Model) -> Opil:
    """The entry :mod:`vcran.sim.protocols` names for ``opil``."""
    return Opil(model)
