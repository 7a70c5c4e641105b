"""Driving an OPIL fleet manager's robots along the roadmap under node reservations (docs/contract.md §12, issue 32 item 4).

The Dispatcher's half of traffic (docs/loop.md, "Routing on a roadmap"). The reservations
(:mod:`vcran.core.traffic.reservations`) decide which robot may drive which nodes; this module turns that
into OPIL tasks and reads the robots' progress back.

* **An errand** is what the manager asks of a robot: drive to a station's dock node, then perform one
  action there (``load``, ``unload``, ``charge``). Its outcome goes back to the manager as the outcome of
  a plain task would: ``"completed"``, or the reason the robot cancelled one of its tasks.
* **One task per stretch.** OPIL hands a task's motions to the AGV as one path once all have arrived
  (R3), and a task never grows afterwards; so each stretch the reservations grant (up to the next waiting
  node or the route's end) is one task, ``{errand}_s{k}``: a motion per node, and, on the stretch that
  ends at the errand's goal, the action after the last one (the station's dock as the last point, with
  its heading). A robot already at its goal gets one task: its dock and the action.
* **Progress** comes from what Orion holds: ``assignment_state``'s ``last_finished_motion`` says which
  nodes of the stretch the robot has reached, and each releases the node behind it; the stretch's task
  completing in ``ran_status`` says the robot is at its end, and the next stretch is asked for. Every
  update that releases or reserves anything gives every robot its turn: stretches granted are sent at once.
* **A cancelled stretch** (a motion failure, a collision with ``collisions = "stop"``, a timeout, a cancel)
  ends the errand for the manager with that reason (it re-plans as it would a plain task), but the robot
  has stopped between nodes it holds, on a route others' plans count on being driven to its end: the
  router drives it on to the route's end without the action (``{errand}_s{k}`` again), and an errand the
  manager sends meanwhile starts there. A robot whose battery ran empty stops where it is until
  :meth:`Router.resume` (its battery swapped).
* **Idle robots in the way.** A robot at rest holds its node, and routes avoid it. When a robot waits
  for a route that an idle robot's node blocks (a dock where it finished its job, say), that idle robot
  is sent to the nearest free waiting node off that route (``park{n}_{robot}``); an errand sent to it
  meanwhile starts where it parks.
* **Start.** Each robot is placed at the node at its start position, or, off the roadmap, at the nearest
  free node: its first task drives there first, straight.

Choices the reservations leave to the manager: routes by length (edges' speed limits are not sent to the
robots); under ``inbound = "polling"`` a stretch's motions go out spaced by more than a poll interval
(``send_task``'s ``every``), since all but the last would be overwritten before the RAN reads them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from vcran.core.manager import Fleet, Handle
from vcran.core.opil.build import PathPoint
from vcran.core.opil.ids import Id, id_for
from vcran.core.opil.messages import AssignmentStatus, Message, RanError, RanStatus
from vcran.core.scenario import POLLING, Job
from vcran.core.traffic.paths import Graph
from vcran.core.traffic.reservations import Reservations

COMPLETED, BATTERY_EMPTY = "completed", "battery_empty"


@dataclass(slots=True)
class Errand:
    """Drive to node ``goal`` and perform ``action`` there (None: only drive), for ``job`` if any."""

    name: str
    goal: str
    dock: PathPoint  # the last point at the goal: the station's dock, with its heading
    action: str | None
    job: Job | None
    report: bool  # its outcome goes to the manager (not a parking errand, nor one already reported)
    sent: int = 0  # stretch tasks sent


@dataclass(slots=True)
class Stretch:
    """A task on its way: the nodes it drives to (reserved), their motions' ids, how many are reached."""

    task: Id
    nodes: tuple[str, ...]
    motions: tuple[Id, ...]
    reached: int = 0


@dataclass(slots=True)
class Robot:
    errand: Errand | None = None
    queued: Errand | None = None  # sent while the robot drives on to the end of a route: starts there
    stretch: Stretch | None = None
    stalled: bool = False  # its battery ran empty on a stretch: waits for resume()


class Router:
    """The fleet's robots on ``fleet.roadmap`` (module docstring). ``free(robot)``: the manager has no work
    for the robot (it may be parked out of the way)."""

    def __init__(self, fleet: Fleet, handle: Handle, free: Callable[[str], bool]) -> None:
        if fleet.roadmap is None:
            raise ValueError("routing on the roadmap needs a scenario with a [roadmap]")
        self.fleet, self.handle, self.free = fleet, handle, free
        self.graph = Graph(fleet.roadmap)
        self.plan = Reservations(self.graph)
        self.robots = {robot: Robot() for robot in fleet.robot_ids}
        self.neighbours: dict[str, set[str]] = {n: set() for n in self.graph.nodes}  # either way
        for e in fleet.roadmap.edges:
            self.neighbours[e.start].add(e.end)
            self.neighbours[e.end].add(e.start)
        self.node_of = {s.id: s.dock_node or _node_at(self.graph, fleet.dock(s.id)) for s in fleet.stations}
        link = fleet.link
        self.every = 1.5 * link.poll_interval + link.jitter if link.inbound == POLLING else 0.0
        self.off: set[str] = set()  # robots placed at a node they are not at yet (they start off the roadmap)
        self._parks = 0
        for robot in fleet.robot_ids:
            self._place(robot)

    # --- the manager's side ---------------------------------------------------------------------------------

    def go(self, robot: str, station: str, action: str, name: str, job: Job | None = None) -> None:
        """Send ``robot`` to ``station``'s dock along the roadmap, to perform ``action`` there; its outcome
        comes back from :meth:`update`."""
        goal = self.node_of[station]
        self.start(robot, Errand(name, goal, self.fleet.dock(station), action, job, report=True))

    def start(self, robot: str, errand: Errand) -> None:
        """Begin ``errand`` now, or where the robot's present route ends (module docstring)."""
        r = self.robots[robot]
        busy = r.errand
        assert busy is None or not busy.report, f"{robot} is on errand {busy.name} already"
        if busy is not None and (r.stretch is not None or robot not in self.plan.pending()):
            r.queued = errand  # it drives on to the end of its route first
            return
        r.errand = errand  # a parking errand still waiting for its route is simply replaced
        if self.plan.held(robot)[0] == errand.goal:
            if robot in self.plan.pending():
                self.plan.request(robot, errand.goal)  # withdraws the parking request (granted at once)
            if errand.action is not None or robot in self.off:
                self._send(robot, ())
            else:
                r.errand = None
            return
        self.plan.request(robot, errand.goal)
        self.advance()

    def update(self, robot: str, message: Message) -> str | None:
        """Take in an update of ``robot``: how its errand ended (``"completed"`` or a cancel reason) when
        this update says so, else None. Progress releases nodes and grants stretches on the way."""
        r = self.robots[robot]
        s = r.stretch
        if s is None:
            return None
        if isinstance(message, AssignmentStatus):
            if self._progress(robot, s, message.last_finished_motion):
                self.advance()
            return None
        outcome = task_outcome(message, s.task)
        if outcome is None:
            return None
        r.stretch = None
        latest = self.handle.latest(robot, "assignment_state")
        done = s.motions[-1] if outcome == COMPLETED and s.motions else None
        if done is None and isinstance(latest, AssignmentStatus):
            done = latest.last_finished_motion
        if done is not None:
            self._progress(robot, s, done)
        errand = r.errand
        assert errand is not None
        told = None
        if outcome != COMPLETED:
            told = outcome if errand.report else None
            errand.report, errand.action, errand.job = False, None, None  # the rest only brings it to rest
            if outcome == BATTERY_EMPTY:
                r.stalled = True
            else:
                self._drive_on(robot)
        if r.stretch is None and not r.stalled and self._arrived(robot, errand):
            if outcome == COMPLETED and errand.report:
                told = COMPLETED
            r.errand, queued, r.queued = None, r.queued, None
            if queued is not None:
                self.start(robot, queued)
        self.advance()
        return told

    def resume(self, robot: str) -> None:
        """``robot``, stopped by an empty battery on a stretch, can drive again: it drives on."""
        r = self.robots[robot]
        if r.stalled:
            r.stalled = False
            self._drive_on(robot)
            self.advance()

    def advance(self) -> None:
        """Grant what can be granted, send the stretches, and park idle robots in the way, until nothing changes."""
        while True:
            for move in self.plan.step():
                self._send(move.robot, move.nodes)
            if not self._unblock():
                return

    # --- inside -----------------------------------------------------------------------------------------

    def _place(self, robot: str) -> None:
        x, y, _ = self.fleet.robot(robot).pose
        node = self.graph.roadmap.node_at(x, y)
        if node is None or node.id in self.plan.holder:
            free = [n for n in self.graph.nodes.values() if n.id not in self.plan.holder]
            if not free:
                raise ValueError(f"the roadmap has fewer nodes than the fleet has robots: no node left for {robot}")
            node = min(free, key=lambda n: math.hypot(n.x - x, n.y - y))  # min keeps the first in file order
            self.off.add(robot)
        self.plan.place(robot, node.id)

    def _send(self, robot: str, nodes: tuple[str, ...]) -> None:
        """One task driving ``robot`` to ``nodes`` (held), with the errand's action if they end at its goal."""
        r = self.robots[robot]
        errand = r.errand
        assert errand is not None
        points: list[PathPoint] = [self._point(n) for n in nodes]
        lead = 0
        if robot in self.off:  # it starts off the roadmap: to its node first
            self.off.discard(robot)
            points.insert(0, self._point(self.plan.held(robot)[0]))
            lead = 1
        actions: list[str] = []
        if errand.action is not None and (nodes[-1] if nodes else self.plan.held(robot)[0]) == errand.goal:
            if nodes:
                points[-1] = errand.dock
            else:
                points.append(errand.dock)  # already there: the dock's heading, then the action
            actions.append(errand.action)
        errand.sent += 1
        name = f"{errand.name}_s{errand.sent}"
        task = self.handle.send_task(robot, points, actions, task=name, job=errand.job if errand.report else None,
                                     every=self.every)
        motions = tuple(id_for(f"{name}_m{i}") for i in range(1 + lead, len(nodes) + 1 + lead))
        r.stretch = Stretch(task, nodes, motions)

    def _point(self, node: str) -> PathPoint:
        n = self.graph.nodes[node]
        return (n.x, n.y)

    def _progress(self, robot: str, s: Stretch, motion: Id) -> bool:
        """The nodes of ``s`` up to ``motion``'s are reached: each releases the one behind it."""
        if motion not in s.motions:
            return False
        k = s.motions.index(motion) + 1
        for node in s.nodes[s.reached:k]:
            self.plan.reached(robot, node)
        moved, s.reached = k > s.reached, max(s.reached, k)
        return moved

    def _drive_on(self, robot: str) -> None:
        """After a cancelled stretch: drive the nodes still held ahead; the rest of the route follows."""
        ahead = self.plan.held(robot)[1:]
        if ahead:
            self._send(robot, ahead)

    def _arrived(self, robot: str, errand: Errand) -> bool:
        return self.plan.held(robot) == (errand.goal,) and robot not in self.plan.routes()

    def _unblock(self) -> bool:
        """Park the idle robots whose nodes block a waiting robot's route (module docstring)."""
        parked = False
        for waiting in self.plan.pending():
            errand = self.robots[waiting].errand
            if errand is None:
                continue
            route = self.graph.route(self.plan.held(waiting)[0], errand.goal)
            if route is None:
                continue
            for node in route.nodes[1:]:
                holder = self.plan.holder.get(node)
                if holder is not None and self._parkable(holder) and self._park(holder, set(route.nodes)):
                    parked = True
        return parked

    def _parkable(self, robot: str) -> bool:
        r = self.robots[robot]
        return (r.errand is None and r.stretch is None and not r.stalled and robot not in self.plan.routes()
                and robot not in self.plan.pending() and self.free(robot))

    def _park(self, robot: str, keep_clear: set[str]) -> bool:
        """Send ``robot`` to the nearest free waiting node not in ``keep_clear``; False if there is none."""
        at = self.plan.held(robot)[0]
        taken = set(self.plan.holder) | keep_clear | {r.errand.goal for r in self.robots.values() if r.errand}
        options = []
        for node in self.graph.nodes.values():
            if node.waiting and node.id not in taken:
                route = self.graph.route(at, node.id)
                if route is not None:
                    options.append((len(self.neighbours[node.id]) > 1, route.cost, node.id))
        if not options:
            return False
        goal = min(options)[2]
        self._parks += 1
        self.start(robot, Errand(f"park{self._parks}_{robot}", goal, self._point(goal), None, None, report=False))
        return True


def task_outcome(message: Message, task: Id) -> str | None:
    """How ``task`` ended according to ``message``: ``"completed"``, a cancel reason, or None (not yet).

    A ``ran_error`` ``battery_empty`` naming the task ends it at once: published when the robot stops
    (its ``ran_status`` follows at the next tick), and the only word on a task the robot refused
    because it was already out of service (a refused task never appears in ``ran_status``)."""
    if isinstance(message, RanStatus):
        if task in message.completed:
            return COMPLETED
        for ended in message.cancelled:
            if ended.task_id == task:
                return ended.reason
    elif isinstance(message, RanError) and message.code == BATTERY_EMPTY and message.task_id == task:
        return BATTERY_EMPTY
    return None


def _node_at(graph: Graph, dock: PathPoint) -> str:
    node = graph.roadmap.node_at(dock[0], dock[1])
    if node is None:  # the scenario reader refuses this (traffic.validate): a roadmap built in code may not
        raise ValueError(f"no roadmap node at the dock {dock[:2]}")
    return node.id
