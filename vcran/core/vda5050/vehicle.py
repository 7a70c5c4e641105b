"""A VDA 5050 vehicle (docs/contract.md §11, chapter 6 of VDA 5050 2.x) as a pure state machine, beside OPIL's RanLogic.

Inputs are method calls carrying the simulated time ``now``: messages from the master (already decoded, or
the :class:`~vcran.core.vda5050.codec.Invalid` the decoder returned), what the body reports (a waypoint
reached, an action ended, a halt, a breakdown, a field violation) and timers. Outputs are the returned
effects (:mod:`vcran.core.vda5050.effects`), in order: commands for the body, messages to publish, events
for the log. The messages themselves are built on demand (:meth:`Vehicle.state`, :meth:`Vehicle.factsheet`
...) from the vehicle and a snapshot of its body, so a driver publishes exactly when told to.

The driver's obligations: deliver ``on_timer`` at each :class:`StartTimer` instant before any input with a
later ``now``; report each waypoint of a :class:`Drive` once, in order, unless a stop or abandon dropped
it; report each :class:`Act` once (``on_acted``) unless an :class:`Interrupt` or a halt ended it. Misuse
(time going backwards, a waypoint or action nobody started) raises
:class:`~vcran.core.vda5050.effects.LocalProtocolError`; nothing a master sends ever raises.

Where VDA 5050 leaves the vehicle a choice, docs/vda5050.md says which one vcran makes.
"""

from __future__ import annotations

from vcran.core.vda5050 import acceptance, errors
from vcran.core.vda5050.actions import FAILED, FINISHED, RUNNING, ActionBook, Run
from vcran.core.vda5050.codec import Invalid
from vcran.core.vda5050.conditions import ConditionsMixin
from vcran.core.vda5050.config import VehicleConfig
from vcran.core.vda5050.effects import (
    Abandon,
    Drive,
    Effect,
    ErrorCleared,
    ErrorRaised,
    Hold,
    LocalProtocolError,
    NodeTag,
    NodeTraversed,
    OrderAccepted,
    OrderDiscarded,
    OrderEnded,
    OrderRejected,
    PublishState,
    Release,
    StartTimer,
    StopAfterLeg,
    StopNow,
    Waypoint,
    Where,
)
from vcran.core.vda5050.enums import ActionScope
from vcran.core.vda5050.header import Stamper
from vcran.core.vda5050.instant import InstantActionsMixin
from vcran.core.vda5050.order import InstantActions, Order
from vcran.core.vda5050.path import Path
from vcran.core.vda5050.reporting import ReportingMixin
from vcran.core.vda5050.state import Error

#: Two instants closer than this are the same instant (seconds; R14's tolerance).
TOLERANCE = 1e-6


class Vehicle(InstantActionsMixin, ConditionsMixin, ReportingMixin):
    """One vehicle's protocol logic. Construct once; feed it inputs in time order."""

    def __init__(self, config: VehicleConfig, *, last_node_id: str = "", last_node_sequence_id: int = 0) -> None:
        self.config = config
        self.stamper = Stamper(config.version, config.manufacturer, config.serial_number, config.epoch)
        self._out: list[Effect] = []
        self.actions = ActionBook(self._out, config.report_paused)
        self.errors = errors.ErrorBook(config.version)
        self.path = Path()
        #: The current (or last) order: None before the first; kept after it ends (§6.10.6).
        self.order_id: str | None = None
        self.order_update_id = 0
        self.zone_set_id: str | None = None
        self.last_node_id = last_node_id
        self.last_node_sequence_id = last_node_sequence_id
        #: The last base node of the order, (nodeId, sequenceId): where an update must stitch (§6.6.2).
        self.decision: tuple[str, int] | None = None
        #: Waypoints sent to the body and not reached yet.
        self.route: list[NodeTag] = []
        self.paused = False
        self.broken = False
        self.out_of_service = False
        self.charging = False
        self.field_violation = False
        self._instant_hold = False
        self._entered: set[int] = set()  # edges whose actions were triggered
        self._leg_began = float("-inf")
        self._odometer_at_node: float | None = None
        self._cancel: Run | None = None  # the cancelOrder in progress
        self._deferred: list[Run] = []  # instant actions waiting for a pause or breakdown to end, or for a charge to start
        self._active = False  # an accepted order that has not ended
        self._now = float("-inf")
        self._forced = False
        self._before: tuple[object, ...] = ()
        self._state_due: float | None = None

    # --- inputs: the master ------------------------------------------------------------------------------

    def start(self, now: float) -> list[Effect]:
        """The vehicle comes up: factsheet and state, as a vehicle publishes them on connecting."""
        self._begin(now)
        self.publish_factsheet()
        self._forced = True
        return self._end()

    def on_order(self, now: float, order: Order | Invalid, where: Where) -> list[Effect]:
        """An ``order`` message (§6.6); ``where``: the body now (for Figure 8 (4))."""
        self._begin(now)
        if isinstance(order, Invalid):
            self._refuse(order.order_id, order.order_update_id, self.invalid_error(order))
        else:
            self._order(now, order, where)
        return self._end()

    def on_instant_actions(self, now: float, message: InstantActions | Invalid, where: Where) -> list[Effect]:
        """An ``instantActions`` message (§6.9): its actions in order, at this instant."""
        self._begin(now)
        if isinstance(message, Invalid):
            self._warn(self.invalid_error(message))
        else:
            for action in message.actions:
                self.instant(now, action, where)
            self._advance(now)
        return self._end()

    def on_timer(self, now: float, key: str) -> list[Effect]:
        """A :class:`StartTimer` is due. ``state``: no state went out for ``state_interval`` (§6.10)."""
        self._begin(now)
        if key == "state" and self._state_due is not None and now + TOLERANCE >= self._state_due:
            self._forced = True
        return self._end()

    # --- inputs: the body --------------------------------------------------------------------------------

    def on_reached(self, now: float, tag: NodeTag, where: Where) -> list[Effect]:
        """The body reached the waypoint of ``tag``: the node is traversed (§6.10.2)."""
        self._begin(now)
        if not self.route or self.route[0] != tag:
            raise LocalProtocolError(f"{self.config.serial_number}: reached {tag}, expected "
                                     f"{self.route[0] if self.route else 'no waypoint'}")
        self.route.pop(0)
        edge, node = self.path.traverse(tag.sequence_id)
        if edge is not None:
            self._entered.discard(edge.sequence_id)
            self.actions.leave_edge(edge.sequence_id)
        self._at_node(node.node_id, node.sequence_id, where)
        if self._cancel is None:
            self.actions.trigger(ActionScope.NODE, node.sequence_id)
            if self.route:  # driving on: the next edge is entered now
                self._enter(self.path.edges[0].sequence_id)
                self._leg_began = now
        self._advance(now)
        return self._end()

    def on_acted(self, now: float, action_id: str, ok: bool = True, message: str = "") -> list[Effect]:
        """The body ended action ``action_id``; a failure says why in ``message`` (§6.11 FAILED)."""
        self._begin(now)
        run = self.actions.get(action_id)
        if run is None or run.status is not RUNNING:
            raise LocalProtocolError(f"{self.config.serial_number}: action {action_id!r} ended but was not running")
        if ok and run.action.action_type in ("startCharging", "stopCharging"):
            self.charging = run.action.action_type == "startCharging"
        self.actions.set(run, FINISHED if ok else FAILED, None if ok or not message else message)
        if not ok:
            refs = [("actionId", action_id), ("actionType", run.action.action_type)]
            if run.of_order and self.order_id is not None:
                refs.append(("orderId", self.order_id))
            self._warn(errors.error(errors.ACTION_FAILED, message or f"{run.action.action_type} failed", refs))
        self._advance(now)
        return self._end()

    # --- orders (§6.6) -----------------------------------------------------------------------------------

    @property
    def executing(self) -> bool:
        """Figure 8 (3): nodeStates not empty, or an action of the order neither FINISHED nor FAILED."""
        return bool(self.path.nodes) or self.actions.order_open()

    def _order(self, now: float, order: Order, where: Where) -> None:
        standing = acceptance.Standing(
            self.order_id, self.order_update_id, self.executing, self._cancel is not None, self.decision,
            (self.last_node_id, self.last_node_sequence_id), self.charging, self.errors.fatal(), where)
        verdict = acceptance.decide(order, standing, self.config)
        if verdict == acceptance.DISCARD:
            self._out.append(OrderDiscarded(order.order_id, order.order_update_id))
            self._forced = True  # the master resent it: it may have missed the state that took it
            return
        if isinstance(verdict, Error):
            self._refuse(order.order_id, order.order_update_id, verdict)
            return
        update = verdict == acceptance.UPDATE
        taken = self._taken(update)
        clash = next((a for n in order.nodes[1 if update else 0:] for a in n.actions if a.action_id in taken), None) \
            or next((a for e in order.edges for a in e.actions if a.action_id in taken), None)
        if clash is not None:
            self._refuse(order.order_id, order.order_update_id, errors.error(
                errors.ORDER, f"actionId {clash.action_id!r} is taken by another action of the vehicle",
                [("orderId", order.order_id), ("orderUpdateId", order.order_update_id), ("actionId", clash.action_id)]))
            return
        for gone in self.errors.clear_warnings():
            self._out.append(ErrorCleared(gone))
        if update:
            self.actions.remove(self.path.stitch(order))
        else:
            self.actions.new_order()
            self.path.load(order)
            self._entered.clear()
        self.order_id, self.order_update_id = order.order_id, order.order_update_id
        if order.zone_set_id is not None or not update:
            self.zone_set_id = order.zone_set_id
        released = [n for n in order.nodes if n.released]
        self.decision = (released[-1].node_id, released[-1].sequence_id)
        self._register(order, skip_first=update)
        self._active = True
        self._out.append(OrderAccepted(order.order_id, order.order_update_id, update))
        if not update:  # the first node is where the vehicle stands: traversed now (§6.6.3.1)
            first = order.nodes[0]
            self._at_node(first.node_id, first.sequence_id, where)
            self.actions.trigger(ActionScope.NODE, first.sequence_id)
        self._advance(now)

    def _taken(self, update: bool) -> set[str]:
        """The actionIds that stay listed if an order is accepted: an update keeps all but the horizon's,
        a new order only the running instant actions (§6.10.6)."""
        if not update:
            return {r.id for r in self.actions.runs.values() if not r.of_order and not r.status.final}
        horizon = {n.sequence_id for n in self.path.nodes if not n.released}
        horizon |= {e.sequence_id for e in self.path.edges if not e.released}
        return {r.id for r in self.actions.runs.values() if not (r.of_order and r.place in horizon)}

    def _register(self, order: Order, skip_first: bool) -> None:
        """List the order's actions as WAITING (§6.11), node and edge ones in sequence order."""
        places = [(n.sequence_id, ActionScope.NODE, n.actions) for n in order.nodes[1 if skip_first else 0:]]
        places += [(e.sequence_id, ActionScope.EDGE, e.actions) for e in order.edges]
        for place, scope, actions in sorted(places, key=lambda p: p[0]):
            for action in actions:
                spec = self.config.action(action.action_type)
                self.actions.add(Run(action, scope, place, spec.interruptible if spec else True))

    def _refuse(self, order_id: str | None, update_id: int | None, e: Error) -> None:
        """§6.6.4: nothing of the order is taken over; the warning stays until an order is accepted."""
        self._out.append(OrderRejected(order_id, update_id, e))
        self._warn(e)

    # --- driving -----------------------------------------------------------------------------------------

    @property
    def driving(self) -> bool:
        """§6.10.6 ``driving``: on a route and not stopped by a pause, breakdown, field or instant action."""
        return bool(self.route) and not (self.paused or self.broken or self.field_violation or self._instant_hold)

    def _advance(self, now: float) -> None:
        """Let the order go as far as it can: start actions, drive on, finish a cancel or the order."""
        if not (self.paused or self.broken):
            self.actions.start_ready()
            self.start_deferred()
        self._hold_for_instant()
        if not (self.paused or self.broken or self.out_of_service) and self._cancel is None:
            self._drive(now)
        if self._cancel is not None and not self.route and not self.actions.order_open():
            self._finish_cancel()
        if self._active and self._cancel is None and not self.path.nodes and not self.route \
                and not self.actions.order_open():
            self._end_order("completed")

    def _drive(self, now: float) -> None:
        if self.charging or self.actions.blocks_driving() or self._instant_hold or not self.path.nodes:
            return
        if not self.route:
            edge = self.path.edges[0] if self.path.edges else None
            if edge is None or not edge.released:
                return
            if edge.sequence_id not in self._entered:
                self._enter(edge.sequence_id)
                self.actions.start_ready()
                if self.actions.blocks_driving():
                    return
        segment = self.path.segment(len(self.route), self._entered)
        if not segment:
            return
        assert self.order_id is not None
        waypoints = []
        for edge, node in segment:
            p = node.node_position
            assert p is not None  # acceptance refuses nodes without one
            tag = NodeTag(self.order_id, node.node_id, node.sequence_id)
            waypoints.append(Waypoint(p.x, p.y, p.theta, edge.max_speed, tag, edge.edge_id))
        if not self.route:
            self._leg_began = now
        self.route.extend(w.tag for w in waypoints)
        self._out.append(Drive(tuple(waypoints)))

    def _enter(self, edge_sequence_id: int) -> None:
        """The vehicle enters an edge: its actions trigger (§6.10.2)."""
        self._entered.add(edge_sequence_id)
        self.actions.trigger(ActionScope.EDGE, edge_sequence_id)

    def _hold_for_instant(self) -> None:
        """A SOFT or HARD instant action holds the vehicle where it is while it runs (§6.12)."""
        hold = self.actions.instant_blocking()
        if hold != self._instant_hold:
            self._instant_hold = hold
            self._out.append(Hold("instant") if hold else Release("instant"))

    def _at_node(self, node_id: str, sequence_id: int, where: Where) -> None:
        self.last_node_id, self.last_node_sequence_id = node_id, sequence_id
        self._odometer_at_node = where.odometer
        self._out.append(NodeTraversed(node_id, sequence_id))

    # --- cancelling (§6.6.3) -----------------------------------------------------------------------------

    def cancel_order(self, now: float, run: Run) -> None:
        """cancelOrder (§6.6.3, Figure 9): waiting actions FAILED, interruptible running ones too; the
        vehicle stops at the next node (or at once, ``stop_between_nodes``); FINISHED once it stands and no
        action of the order runs."""
        if self._cancel is not None or not self.executing:
            self.actions.set(run, FAILED)
            self._warn(errors.error(errors.NO_ORDER_TO_CANCEL, "no order to cancel (§6.6.3.2)",
                                    [("actionId", run.id)]))
            return
        self._cancel = run
        self.actions.cancel()
        if self.route and abs(now - self._leg_began) <= TOLERANCE:
            self._out.append(Abandon())  # the leg began at this instant: the vehicle stays on its node
            self.route.clear()
        elif self.route and self.config.stop_between_nodes:
            self._out.append(StopNow())
            self.route.clear()
        elif self.route:
            self._out.append(StopAfterLeg())
            del self.route[1:]
        if self.route:
            self.path.keep_next_node()
        else:
            self.path.clear()
        self._entered.clear()
        if self.route or self.actions.order_open():
            self.actions.set(run, RUNNING)

    def _finish_cancel(self) -> None:
        assert self._cancel is not None
        self.path.clear()
        self.actions.set(self._cancel, FINISHED)
        self._cancel = None
        if self._active:
            self._end_order("cancelled")

    def _end_order(self, how: str) -> None:
        self._active = False
        self._out.append(OrderEnded(self.order_id or "", how))

    # --- errors ------------------------------------------------------------------------------------------

    def _warn(self, e: Error) -> None:
        self._raised(self.errors.warn(e))

    def _raised(self, e: Error | None) -> None:
        if e is not None:
            self._out.append(ErrorRaised(e))

    def _cleared(self, e: Error | None) -> None:
        if e is not None:
            self._out.append(ErrorCleared(e))

    # --- bookkeeping -------------------------------------------------------------------------------------

    def _begin(self, now: float) -> None:
        if now < self._now:
            raise LocalProtocolError(f"{self.config.serial_number}: time went backwards from {self._now} to {now}")
        self._now = now
        self._before = self.seen()

    def _end(self) -> list[Effect]:
        """Publish a state if anything it shows changed (§6.10: "relevant events"), or when asked."""
        if self._forced or self.seen() != self._before:
            self._forced = False
            self._out.append(PublishState())
            self._state_due = self._now + self.config.state_interval
            self._out.append(StartTimer("state", self._state_due))
        out, self._out[:] = list(self._out), []
        return out

    def seen(self) -> tuple[object, ...]:
        """What a state message shows of the vehicle's logic, cheaply comparable (the body's telemetry, which
        changes all the time, is not an event)."""
        return (self.order_id, self.order_update_id, self.zone_set_id, self.last_node_id, self.last_node_sequence_id,
                self.path.version, self.actions.states(), self.errors.listed(), self.driving, self.paused,
                self.charging, self.field_violation, self.new_base_request)
