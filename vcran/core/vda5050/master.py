"""The VDA 5050 master interface (docs/contract.md §11, §9): what users subclass, and the handle their master acts through.

The counterpart of OPIL's :class:`vcran.FleetManager`, built the same way: a few hooks with plain arguments.
vcran calls them on a :class:`Master`:

* :meth:`~Master.on_start` once, before anything else, with ``self.fleet`` and ``self.handle`` set;
* :meth:`~Master.on_job` when a job of the scenario's workload reaches the master;
* :meth:`~Master.on_state` for every ``state`` message a vehicle publishes that reaches the master, and
  :meth:`~Master.on_connection`, :meth:`~Master.on_factsheet` for ``connection`` and ``factsheet``;
  :meth:`~Master.on_visualization` only for a master whose :attr:`~Master.topics` lists it (to any other
  master no visualization comes at all, as live).

The master acts through its :class:`MasterHandle`: it sends orders and instant actions (stamped with
their headers, numbered by an :class:`~vcran.core.vda5050.builder.OrderLine` per vehicle), schedules
callbacks of its own, reads the latest message of each topic from each vehicle, draws from a seeded
random generator and reports jobs done or failed. It never sees a vehicle's insides: what it knows is
what the vehicles published. The same object runs in simulated time and live against an MQTT broker:
only the handle's primitives differ. Pure, like the core.

What the loop that hosts a master provides (a subclass of :class:`MasterHandle`, and the calls):

- the primitives :attr:`MasterHandle.now`, :meth:`MasterHandle.call_at` and :meth:`MasterHandle._publish`
  (an ``order`` or ``instantActions`` message onto the vehicle's topic, over the link);
- ``master._bind(fleet, handle)``, then ``on_start``; each job at its time (``handle._jobs.arrived`` first,
  then ``on_job``); each message that reaches the master: ``handle._heard(serial, message)``, then the hook
  :data:`HOOKS` names for its topic, if :meth:`Master.hears` it; timers as they fall due.

The time-based helpers and job reports (``call_later``, ``job_done``, ``job_failed``) and the hooks
``on_start``, ``on_job`` and ``_bind`` are the shared manager's and handle's (:mod:`vcran.core.manager`,
every protocol's); :class:`Master` and :class:`MasterHandle` add only what is VDA 5050's.
"""

from __future__ import annotations

import random
from collections.abc import Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Any, ClassVar

from vcran.core.manager import Handle, Manager
from vcran.core.vda5050.builder import OrderLine, Stop, action
from vcran.core.vda5050.enums import ConnectionState, Topic
from vcran.core.vda5050.factsheet import Factsheet
from vcran.core.vda5050.fleet import MasterFleet
from vcran.core.vda5050.header import Header, timestamp
from vcran.core.vda5050.order import Action, InstantActions, Order
from vcran.core.vda5050.state import Connection, State, Visualization

if TYPE_CHECKING:  # types only: VDA 5050 imports nothing of OPIL's, which the scenario module still does
    from vcran.core.jobs import JobBook
    from vcran.core.scenario import Job

#: What a vehicle publishes to its master.
Heard = State | Connection | Factsheet | Visualization

#: The hook each topic a master hears calls.
HOOKS: dict[Topic, str] = {Topic.STATE: "on_state", Topic.CONNECTION: "on_connection",
                           Topic.FACTSHEET: "on_factsheet", Topic.VISUALIZATION: "on_visualization"}
_TOPIC_OF: dict[type, Topic] = {State: Topic.STATE, Connection: Topic.CONNECTION, Factsheet: Topic.FACTSHEET,
                                Visualization: Topic.VISUALIZATION}


def topic_of(message: Heard) -> Topic:
    """The topic a vehicle publishes ``message`` on."""
    return _TOPIC_OF[type(message)]


class MasterHandle(Handle):
    """How a master acts on its fleet. Subclasses (simulated, live) provide the three primitives
    :attr:`now`, :meth:`call_at` (the shared handle's) and :meth:`_publish`; everything else is built on them.

    ``random`` is seeded from the scenario (``random.Random("manager:{seed}")``): draw from it, never from
    the global generator, and a run stays byte-identical (docs/contract.md §5).
    """

    fleet: MasterFleet  # type: ignore[assignment]  # a VDA 5050 master's fleet: vehicles by serial number

    def __init__(self, fleet: MasterFleet, jobs: JobBook, rng: random.Random) -> None:
        super().__init__(fleet, jobs, rng)  # type: ignore[arg-type]
        self._lines = {s: OrderLine(fleet.vehicle(s).config.map_id) for s in fleet.serials}
        self._header_ids: dict[tuple[str, Topic], int] = {}
        self._latest: dict[tuple[str, Topic], Heard] = {}
        self._orders_sent = 0
        self._actions_sent = 0
        self._assigned: set[str] = set()  # orderIds recorded as a job's work

    # --- primitives --------------------------------------------------------------------------------------

    def _publish(self, serial: str, topic: Topic, message: Order | InstantActions) -> None:
        """Send ``message`` on ``topic`` (``order`` or ``instantActions``) of vehicle ``serial``."""
        raise NotImplementedError

    # --- what reaches the master (the loop calls this before the hook) -------------------------------------

    def _heard(self, serial: str, message: Heard) -> None:
        self._latest[(self._serial(serial), topic_of(message))] = message

    # --- sending -----------------------------------------------------------------------------------------

    def order(self, serial: str, route: Sequence[str | Stop], *, base: int | None = None,
              actions: Sequence[Action] = (), order_id: str | None = None, job: Job | str | None = None) -> Order:
        """Send ``serial`` a new order along ``route`` and return it.

        ``route``: roadmap node ids or :class:`~vcran.core.vda5050.builder.Stop`\\ s, the first where the
        vehicle stands; the first ``base`` released (None: all); ``actions`` performed at the last node.
        The order is named ``order_id``, or ``order_1``, ``order_2``, ... in the order sent; ``job`` records
        it as work for that job (a ``job_assigned`` event; the job's robot becomes this vehicle's).
        """
        line = self._lines[self._serial(serial)]
        stops = self._stops(route, actions)
        name = order_id if order_id is not None else f"order_{self._orders_sent + 1}"
        order = line.new(self._header(serial, Topic.ORDER), name, stops, base)
        self._orders_sent += 1
        if job is not None:
            self._jobs.assigned(self.now, job, self.fleet.vehicle(serial).robot.id, name)
        self._publish(serial, Topic.ORDER, order)
        return order

    def extend(self, serial: str, route: Sequence[str | Stop], *, base: int | None = None,
               actions: Sequence[Action] = ()) -> Order:
        """Send ``serial`` the next update of its current order and return it: ``route`` continues from the
        decision point (the last node released so far, which the update repeats as its stitching node),
        its first ``base`` nodes released (None: all), the rest the new horizon (§6.6.2)."""
        line = self._lines[self._serial(serial)]
        order = line.update(self._header(serial, Topic.ORDER), self._stops(route, actions), base)
        self._publish(serial, Topic.ORDER, order)
        return order

    def resend(self, serial: str) -> Order:
        """Send ``serial``'s last order (or update) again, with a new header: orders travel at QoS 0 (§6.2), and
        a vehicle that had it already discards the copy and publishes its state (§6.6.4.3)."""
        line = self._lines[self._serial(serial)]
        if line.last is None:
            raise ValueError(f"resend: {serial} was sent no order")
        order = replace(line.last, header=self._header(serial, Topic.ORDER))
        self._publish(serial, Topic.ORDER, order)
        return order

    def instant(self, serial: str, action_type: str, blocking: str = "NONE", **parameters: Any) -> str:
        """Send one instant action (``cancelOrder``, ``startPause``, ``startCharging`` ...) and return its
        actionId: ``{action_type}_{n}``, counted over the whole fleet."""
        self._actions_sent += 1
        action_id = f"{action_type}_{self._actions_sent}"
        self.send_instant_actions(serial, [action(action_type, action_id, blocking, **parameters)])
        return action_id

    def send_instant_actions(self, serial: str, actions: Sequence[Action]) -> InstantActions:
        """Send ``actions`` as one ``instantActions`` message (§6.9)."""
        message = InstantActions(header=self._header(serial, Topic.INSTANT_ACTIONS), actions=tuple(actions))
        self._publish(serial, Topic.INSTANT_ACTIONS, message)
        return message

    def send(self, serial: str, message: Order | InstantActions) -> None:
        """Send a message built by hand, as it is (its header too): for tests of a vehicle's rejections."""
        topic = Topic.ORDER if isinstance(message, Order) else Topic.INSTANT_ACTIONS
        self._publish(self._serial(serial), topic, message)

    # --- reading what the vehicles published -------------------------------------------------------------

    def state(self, serial: str) -> State | None:
        """The latest ``state`` of ``serial`` that reached the master, or None before the first."""
        found = self._latest.get((self._serial(serial), Topic.STATE))
        return found if isinstance(found, State) else None

    def connection(self, serial: str) -> ConnectionState | None:
        found = self._latest.get((self._serial(serial), Topic.CONNECTION))
        return found.connection_state if isinstance(found, Connection) else None

    def factsheet(self, serial: str) -> Factsheet | None:
        found = self._latest.get((self._serial(serial), Topic.FACTSHEET))
        return found if isinstance(found, Factsheet) else None

    def position(self, serial: str) -> tuple[float, float, float]:
        """``serial``'s latest known pose ``(x, y, theta)``: from the newer of its latest state and, for a master
        that hears ``visualization``, its latest visualization; else where it started. A master that does not
        hear visualization (the default) knows the pose its vehicles' states show: a state comes on every
        event (an order accepted, each node traversed, an action's change ...) and at least every
        ``state_interval``, so between two nodes the pose is the one at the last node."""
        latest = None
        for topic in (Topic.STATE, Topic.VISUALIZATION):
            message = self._latest.get((self._serial(serial), topic))
            if isinstance(message, State | Visualization) and message.agv_position is not None:
                if latest is None or message.header.timestamp >= latest.header.timestamp:
                    latest = message
        if latest is not None and latest.agv_position is not None:
            p = latest.agv_position
            return p.x, p.y, p.theta
        return self.fleet.vehicle(serial).robot.pose

    def line(self, serial: str) -> OrderLine:
        """What ``serial`` was last sent: orderId, orderUpdateId, decision point."""
        return self._lines[self._serial(serial)]

    # --- helpers -----------------------------------------------------------------------------------------

    def _header(self, serial: str, topic: Topic) -> Header:
        """The next header of ``topic`` to ``serial``: headerId counts per topic and vehicle (§6.4)."""
        agv = self.fleet.vehicle(serial)
        n = self._header_ids.get((serial, topic), 0)
        self._header_ids[(serial, topic)] = n + 1
        return Header(n, timestamp(self.now, agv.config.epoch), agv.config.version.value, agv.config.manufacturer,
                      agv.serial_number)

    def _stops(self, route: Sequence[str | Stop], actions: Sequence[Action]) -> list[Stop]:
        if isinstance(route, str):
            raise TypeError(f"a route is a list of node ids or Stops, got the string {route!r}")
        stops = self.fleet.stops(route)
        if actions:
            if not stops:
                raise ValueError("actions at the end of an empty route")
            last = stops[-1]
            stops[-1] = Stop(last.node_id, last.x, last.y, last.theta, (*last.actions, *actions), last.max_speed)
        return stops

    def _serial(self, serial: str) -> str:
        self.fleet.vehicle(serial)  # a vehicle that does not exist: a clear error, not a silent topic
        return serial


class Master(Manager):
    """Subclass this and override the hooks you need; the defaults do nothing.

    vcran sets :attr:`fleet` and :attr:`handle` before it calls :meth:`on_start`. Hooks run at simulated
    instants in a documented order (updates, then jobs, then timers, as for ``vcran.FleetManager``) and must
    not block: to wait, schedule a callback with ``self.handle.call_later``. :attr:`topics` says which
    topics' messages call a hook, and the master hears only those, as live (``vcran manage --mqtt`` subscribes
    to ``visualization`` only for a master that lists it): every message that reaches it refreshes what the
    handle reads, and without ``visualization`` in :attr:`topics` none of it reaches the master (the vehicles
    build none for it). The default is all but ``visualization``, which each vehicle publishes every telemetry
    period: ``self.handle.position(serial)`` then reads the pose of each vehicle's latest state.
    """

    #: The topics whose messages call a hook (``state``, ``connection``, ``factsheet``, ``visualization``).
    topics: ClassVar[frozenset[str]] = frozenset({"state", "connection", "factsheet"})

    fleet: MasterFleet  # type: ignore[assignment]
    handle: MasterHandle  # type: ignore[assignment]

    def on_state(self, serial: str, state: State) -> None:
        """Vehicle ``serial`` published ``state`` (on every event of §6.10, and at least every 30 s)."""

    def on_connection(self, serial: str, connection: Connection) -> None:
        """``serial``'s connection topic changed: ONLINE, OFFLINE, or the broker's CONNECTIONBROKEN."""

    def on_factsheet(self, serial: str, factsheet: Factsheet) -> None:
        """``serial`` published its factsheet (at start, and on a factsheetRequest)."""

    def on_visualization(self, serial: str, visualization: Visualization) -> None:
        """``serial``'s position and velocity (only with ``"visualization"`` in :attr:`topics`)."""

    def hears(self, topic: Topic) -> bool:
        """Whether a message on ``topic`` calls this master's hook."""
        return topic.value in self.topics
