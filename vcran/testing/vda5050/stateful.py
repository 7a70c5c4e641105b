"""A hypothesis state machine that drives the VDA 5050 vehicle on a bench and checks it against the
reference model of its acceptance rules (docs/contract.md §11, issue 31 item 6; the OPIL twin is
:mod:`vcran.testing.stateful`).

A master sends orders (walks on a 3 x 3 grid of nodes, some with a horizon, some with actions, some with a
defect), updates (continuing from the decision point or the last node, or from elsewhere; with a higher,
equal or lower orderUpdateId), cancels, pauses and other instant actions, and malformed messages; the body
reaches waypoints and ends actions when the machine says so. After each message the vehicle's verdict
(accepted, updated, discarded, refused with which errorType) must be the model's, computed from the
state before it; after every step the invariants below hold on the vehicle alone.

Run it in a test module::

    from vcran.testing.vda5050.stateful import VehicleMachine
    TestVehicle = VehicleMachine.TestCase
"""

from __future__ import annotations

from dataclasses import replace

from vcran.testing._extra import require_hypothesis

require_hypothesis(__name__)

from hypothesis import event
from hypothesis import strategies as st
from hypothesis.control import currently_in_test_context
from hypothesis.stateful import RuleBasedStateMachine, initialize, invariant, precondition, rule

from vcran.core.vda5050.config import VehicleConfig
from vcran.core.vda5050.effects import Effect, OrderAccepted, OrderDiscarded, OrderRejected
from vcran.core.vda5050.enums import ActionStatus, Version
from vcran.core.vda5050.order import Action, Order
from vcran.testing.vda5050.harness import Bench
from vcran.testing.vda5050.model import DISCARD, NEW, UPDATE, ReferenceVehicle
from vcran.testing.vda5050.plans import MANUFACTURER, SERIAL, action, instant, order

#: The grid: node ``n<i>`` at (i % 3, i // 3), metres.
NODES = {f"n{i}": (float(i % 3), float(i // 3)) for i in range(9)}
ORDER_IDS = ["o1", "o2", "o3"]
#: (type, blocking, parameters): actions the vehicle performs, and two it refuses (§6.6.4.2).
ACTIONS = [("pick", "HARD", {}), ("drop", "SOFT", {}), ("finePositioning", "SOFT", {}),
           ("waitForTrigger", "NONE", {"triggerType": "button"}), ("waitForTrigger", "HARD", {"triggerType": "b"}),
           ("startCharging", "NONE", {}), ("pick", "NONE", {}), ("detectObject", "HARD", {})]
FINAL = (ActionStatus.FINISHED, ActionStatus.FAILED)


def neighbours(node: str) -> list[str]:
    x, y = NODES[node]
    return [n for n, (a, b) in NODES.items() if abs(a - x) + abs(b - y) == 1]


def walk(start: str, steps: list[int]) -> list[str]:
    """A walk on the grid from ``start``: each step picks a neighbour (revisits make loops)."""
    out = [start]
    for s in steps:
        options = neighbours(out[-1])
        out.append(options[s % len(options)])
    return out


class VehicleMachine(RuleBasedStateMachine):
    """The vehicle against :class:`~vcran.testing.vda5050.model.ReferenceVehicle`; see the module docstring."""

    def __init__(self) -> None:
        super().__init__()
        self._setup(Version.V2_1_0, False)

    def _setup(self, version: Version, stop_between_nodes: bool) -> None:
        self.config = VehicleConfig(MANUFACTURER, SERIAL, version=version, stop_between_nodes=stop_between_nodes)
        self.bench = Bench(self.config, x=0.0, y=0.0)
        self.model = ReferenceVehicle(self.config)
        self.instant_ids: set[str] = set()
        self.blocking: dict[str, str] = {}  # actionId -> blocking type, of the order's actions
        self.finals: dict[str, ActionStatus] = {}
        self.counter = 0
        self.sent: list[Order] = []

    @initialize(version=st.sampled_from(list(Version)), stop_between_nodes=st.booleans())
    def configure(self, version: Version, stop_between_nodes: bool) -> None:
        self._setup(version, stop_between_nodes)

    # --- the master -------------------------------------------------------------------------------------

    @rule(order_id=st.sampled_from(ORDER_IDS), steps=st.lists(st.integers(0, 3), max_size=4),
          base=st.integers(1, 5), here=st.booleans(), update_id=st.sampled_from([0, 0, 1, 3]),
          actions=st.lists(st.tuples(st.integers(0, 4), st.integers(0, len(ACTIONS) - 1)), max_size=3),
          defect=st.sampled_from([None] * 6 + ["sequence", "map"]))
    def new_order(self, order_id: str, steps: list[int], base: int, here: bool, update_id: int,
                  actions: list[tuple[int, int]], defect: str | None) -> None:
        """An order from where the vehicle is (``here``: its last node, or a point where it stands) or from
        a node elsewhere."""
        names = self._from_here(steps) if here else walk("n8", steps)
        self._send(self._build(order_id, update_id, names, 0, base, actions, defect))

    @rule(kind=st.sampled_from(["decision", "decision", "last", "elsewhere"]), delta=st.sampled_from([1, 1, 2, 0, -1]),
          steps=st.lists(st.integers(0, 3), min_size=1, max_size=3), base=st.integers(1, 4),
          actions=st.lists(st.tuples(st.integers(0, 3), st.integers(0, 5)), max_size=2))
    def update(self, kind: str, delta: int, steps: list[int], base: int, actions: list[tuple[int, int]]) -> None:
        """An update of the vehicle's order: stitching at the decision point (Figure 8 (7)), at the last
        node (8), or somewhere else; its orderUpdateId one or two higher, the same, or lower."""
        state = self.bench.last
        if not state.order_id:
            return
        released = [n for n in state.node_states if n.released]
        if kind == "decision" and released:
            node, seq = released[-1].node_id, released[-1].sequence_id
        elif kind in ("decision", "last") and state.last_node_id in NODES:
            node, seq = state.last_node_id, state.last_node_sequence_id
        else:
            node, seq = "n4", state.last_node_sequence_id + 2
        uid = max(0, state.order_update_id + delta)
        self._send(self._build(state.order_id, uid, walk(node, steps), seq, base, actions, None))

    @rule(pick=st.integers(0, 100))
    def resend(self, pick: int) -> None:
        """A master resends an order it sent before (§6.6.4.3: "the second order will be ignored" when it is
        the current update)."""
        if self.sent:
            self._send(self.sent[pick % len(self.sent)])

    @rule()
    def cancel(self) -> None:
        before = self.bench.last
        expected = self.model.cancel(before, self.instant_ids)
        action_id = self._instant(action("cancelOrder", self._id("c"), "NONE"))
        status = {a.action_id: a.action_status for a in self.bench.last.action_states}[action_id]
        got = "noOrderToCancel" if status is ActionStatus.FAILED else "cancel"
        if currently_in_test_context():
            event(f"cancelOrder: {got}")
        assert got == expected, f"cancelOrder: the vehicle says {got}, the model {expected}"

    @rule(kind=st.sampled_from(["startPause", "stopPause", "stateRequest", "waitForTrigger"]))
    def instant(self, kind: str) -> None:
        params = {"triggerType": "button"} if kind == "waitForTrigger" else {}
        self._instant(action(kind, self._id("i"), "NONE", **params))

    @rule(raw=st.sampled_from([b"{", b"[]", b'{"orderId": "o1"}']))
    def malformed(self, raw: bytes) -> None:
        before = self._view()
        effects = self.bench.order(raw)
        assert self._verdict(effects) == "validationError" and self._view() == before

    # --- the body and time ------------------------------------------------------------------------------

    @precondition(lambda self: bool(self.bench.route) and not self.bench.holds)
    @rule()
    def reach(self) -> None:
        self.bench.reach()

    @precondition(lambda self: bool(self.bench.acting))
    @rule(pick=st.integers(0, 10), ok=st.booleans())
    def finish(self, pick: int, ok: bool) -> None:
        running = sorted(self.bench.acting)
        self.bench.finish(running[pick % len(running)], ok, "" if ok else "it failed")

    @rule(dt=st.sampled_from([0.5, 1.0, 31.0]))
    def tick(self, dt: float) -> None:
        self.bench.at(self.bench.now + dt)

    # --- invariants -------------------------------------------------------------------------------------

    @invariant()
    def rules_hold(self) -> None:
        """After every step, on the vehicle alone (one invariant, so that printed examples stay short)."""
        s, bench = self.bench.last, self.bench
        numbers = [n.sequence_id for n in s.node_states]
        assert numbers == sorted(set(numbers)), "§6.10.2: nodeStates in sequence order"
        assert all(n > s.last_node_sequence_id for n in numbers) or s.order_id == "", "nodes ahead of the last"
        released = [n.released for n in s.node_states]
        assert released == sorted(released, reverse=True), "§6.6.1: the base before the horizon"
        ahead = [(n.node_id, n.sequence_id) for n in s.node_states[:len(bench.route)]]
        assert [(w.tag.node_id, w.tag.sequence_id) for w in bench.route] == ahead and all(
            n.released for n in s.node_states[:len(bench.route)]), "§6.6.1: only the base is driven, in order"
        assert not s.driving or (bench.route and not s.paused), "driving: on a route, not paused"
        assert s.paused == ("pause" in bench.holds), "startPause holds the body"
        running = {a.action_id for a in s.action_states if a.action_status is ActionStatus.RUNNING
                   and a.action_type != "cancelOrder"}
        assert set(bench.acting) == running, "the body performs exactly the running actions"
        order_running = [a for a in running if a in self.blocking]
        if any(self.blocking[a] == "HARD" for a in order_running):
            assert len(order_running) == 1, "§6.12: HARD runs alone"
        if any(self.blocking[a] != "NONE" for a in order_running):
            assert not bench.route, "§6.12: no driving while a SOFT or HARD action runs"
        listed = {a.action_id: a.action_status for a in s.action_states}
        for action_id, status in listed.items():  # while an action stays listed (a new order removes it)
            if action_id in self.finals:
                assert status is self.finals[action_id], f"{action_id}: FINISHED and FAILED are final"
            elif status in FINAL:
                self.finals[action_id] = status
        self.finals = {k: v for k, v in self.finals.items() if k in listed}

    # --- helpers ----------------------------------------------------------------------------------------

    def _id(self, prefix: str) -> str:
        self.counter += 1
        return f"{prefix}{self.counter}"

    def _from_here(self, steps: list[int]) -> list[str]:
        """A walk from the node the vehicle stands on, or from a temporary node ``here`` where it stands
        (§6.6.3.1) to the nearest grid node and on."""
        at = (self.bench.x, self.bench.y)
        nearest = min(NODES, key=lambda n: (abs(NODES[n][0] - at[0]) + abs(NODES[n][1] - at[1]), n))
        if NODES[nearest] == at:
            return walk(nearest, steps)
        return ["here", *walk(nearest, steps)]

    def _build(self, order_id: str, update_id: int, names: list[str], start: int, base: int,
               actions: list[tuple[int, int]], defect: str | None) -> Order:
        points = [(n, *(NODES[n] if n in NODES else (self.bench.x, self.bench.y))) for n in names]
        on: dict[str, list[Action]] = {}
        for where, which in actions:
            kind, blocking, params = ACTIONS[which]
            name = names[where % len(names)]
            a = action(kind, self._id("a"), blocking, **params)
            on.setdefault(name, []).append(a)
            self.blocking[a.action_id] = blocking
        built = order(order_id, update_id, points, base=min(base, len(points)), start=start, node_actions=on,
                      map_id="elsewhere" if defect == "map" else "map", version=self.config.version)
        if defect == "sequence" and len(built.nodes) > 1:
            built = replace(built, nodes=(built.nodes[0], replace(built.nodes[1], sequence_id=99), *built.nodes[2:]))
        return built

    def _send(self, o: Order) -> None:
        self.sent.append(o)
        before, where = self.bench.last, self.bench.where()
        expected = self.model.order(before, o, where, self.instant_ids)
        view = self._view()
        got = self._verdict(self.bench.order(o))
        if currently_in_test_context():  # --hypothesis-show-statistics
            event(f"order: {got}")
        assert got == expected, f"order {o.order_id}/{o.order_update_id}: the vehicle says {got}, the model {expected}"
        after = self.bench.last
        if got == NEW:
            assert (after.order_id, after.order_update_id) == (o.order_id, o.order_update_id)
            assert (after.last_node_id, after.last_node_sequence_id) == (o.nodes[0].node_id, o.nodes[0].sequence_id)
        elif got == UPDATE:
            assert after.order_update_id == o.order_update_id
            tail = [(n.node_id, n.sequence_id, n.released) for n in o.nodes[1:]]
            nodes = [(n.node_id, n.sequence_id, n.released) for n in after.node_states]
            assert not tail or nodes[-len(tail):] == tail, "Figure 8 (9): the update's nodes appended"
        else:
            assert self._view() == view, "a refused or discarded order changed the vehicle"

    def _instant(self, a: Action) -> str:
        self.instant_ids.add(a.action_id)
        self.bench.instant(instant(a, version=self.config.version))
        return a.action_id

    def _view(self) -> tuple[object, ...]:
        s = self.bench.last
        return (s.order_id, s.order_update_id, s.last_node_id, s.last_node_sequence_id,
                [(n.node_id, n.sequence_id) for n in s.node_states], list(self.bench.route))

    @staticmethod
    def _verdict(effects: list[Effect]) -> str:
        for e in effects:
            if isinstance(e, OrderAccepted):
                return UPDATE if e.update else NEW
            if isinstance(e, OrderDiscarded):
                return DISCARD
            if isinstance(e, OrderRejected):
                return e.error.error_type
        raise AssertionError(f"no verdict in {effects}")


__all__ = ["VehicleMachine"]
