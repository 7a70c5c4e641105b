"""A vehicle's actions: their states (§6.11) and when each may start (§6.12, Figure 17).

Every action of the current order is listed from the moment the order arrives (WAITING: "the node where
it triggers was not yet reached or the edge where it is active was not yet entered"), every instant
action from the moment it arrives. Reaching a node (or entering an edge) *triggers* its actions: they
join the queue of actions to start, in their order on the node. Figure 17 ("Handling multiple actions")
is the start rule, read for a queue:

- NONE and SOFT actions start together, in parallel ("Add action to parallel execution list");
- a HARD action waits until no other action of the order runs ("Execute actions from parallel execution
  list; Execute HARD action") and, while it runs, nothing else of the order starts ("HARD: Action shall
  not be executed in parallel with other actions");
- the vehicle does not drive while a SOFT or HARD action of its order waits or runs ("stop driving").

Instant actions run at once, beside the order's (docs/vda5050.md: a HARD instant action does not stop
the order's actions). An edge's actions end when the vehicle leaves the edge (§6.6.6: "When the AGV leaves
the edge, the action will stop"): running ones are stopped and reported FINISHED.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from vcran.core.vda5050.effects import Act, ActionChanged, Effect, Interrupt
from vcran.core.vda5050.enums import ActionScope, ActionStatus, BlockingType
from vcran.core.vda5050.order import Action
from vcran.core.vda5050.state import ActionState

WAITING, RUNNING, PAUSED = ActionStatus.WAITING, ActionStatus.RUNNING, ActionStatus.PAUSED
FINISHED, FAILED = ActionStatus.FINISHED, ActionStatus.FAILED
INSTANT = ActionScope.INSTANT
HARD, NONE = BlockingType.HARD, BlockingType.NONE


@dataclass(slots=True)
class Run:
    """One action and where it stands. ``place``: the sequenceId of its node or edge (-1: instant)."""

    action: Action
    scope: ActionScope
    place: int
    interruptible: bool
    status: ActionStatus = WAITING
    held: bool = False  # running, but the vehicle is paused or broken down
    result: str | None = None
    #: The action's id and blocking type, and whether it is the order's (not instant): asked of every action at
    #: every step of the vehicle, plain attributes rather than properties (a Python call each).
    id: str = field(init=False)
    blocking: BlockingType = field(init=False)
    of_order: bool = field(init=False)

    def __post_init__(self) -> None:
        self.id, self.blocking, self.of_order = self.action.action_id, self.action.blocking_type, self.scope is not INSTANT


class ActionBook:
    """The actionStates of one vehicle; changes are reported into ``out``."""

    def __init__(self, out: list[Effect], report_paused: bool) -> None:
        self._out = out
        self._report_paused = report_paused
        self.runs: dict[str, Run] = {}
        self._queue: list[Run] = []  # triggered order actions, not started yet, in trigger order
        self._states: tuple[ActionState, ...] | None = ()

    # --- listing ----------------------------------------------------------------------------------------

    def add(self, run: Run, announce: bool = False) -> None:
        self.runs[run.id] = run
        self._states = None
        if announce:
            self._report(run)

    def get(self, action_id: str) -> Run | None:
        return self.runs.get(action_id)

    def remove(self, places: set[int]) -> None:
        """Forget the (waiting) actions of the horizon nodes and edges at ``places``: an update replaced them."""
        gone = [r.id for r in self.runs.values() if r.of_order and r.place in places]
        for action_id in gone:
            del self.runs[action_id]
        self._queue = [r for r in self._queue if r.id not in gone]
        self._states = None

    def new_order(self) -> None:
        """§6.10.6: "Action states, except for running instant actions, are removed upon receiving a new order"."""
        self.runs = {k: r for k, r in self.runs.items() if not r.of_order and not r.status.final}
        self._queue = []
        self._states = None

    def states(self) -> tuple[ActionState, ...]:
        if self._states is None:
            self._states = tuple([
                ActionState(action_id=r.id, action_type=r.action.action_type,
                            action_description=r.action.action_description,
                            action_status=PAUSED if r.held and self._report_paused else r.status,
                            result_description=r.result)
                for r in self.runs.values()])
        return self._states

    # --- the order's actions ----------------------------------------------------------------------------

    def trigger(self, scope: ActionScope, place: int) -> None:
        """The vehicle reached the node (entered the edge) at ``place``: its waiting actions queue up."""
        queue = self._queue
        for r in self.runs.values():
            if r.scope is scope and r.place == place and r.status is WAITING and r not in queue:
                queue.append(r)

    def start_ready(self) -> None:
        """Start what Figure 17 lets start now (module docstring)."""
        running = [r for r in self.runs.values() if r.of_order and r.status is RUNNING]
        for r in running:
            if r.blocking is HARD:
                return
        while self._queue:
            run = self._queue[0]
            if run.blocking is HARD:
                if running:
                    return
                self._queue.pop(0)
                self.start(run)
                return
            self._queue.pop(0)
            self.start(run)
            running.append(run)

    def blocks_driving(self) -> bool:
        """A SOFT or HARD action of the order is queued or running (Figure 17: "stop driving")."""
        # loops, not any() over generators: asked at every step of the vehicle (issue 31's 100-vehicle hour)
        for r in self._queue:
            if r.blocking is not NONE:
                return True
        for r in self.runs.values():
            if r.of_order and r.status is RUNNING and r.blocking is not NONE:
                return True
        return False

    def order_open(self) -> bool:
        """An action of the order is neither FINISHED nor FAILED (Figure 8 (3))."""
        for r in self.runs.values():
            if r.of_order and r.status is not FINISHED and r.status is not FAILED:
                return True
        return False

    def order_running(self) -> bool:
        return any(r.of_order and r.status is RUNNING for r in self.runs.values())

    def leave_edge(self, place: int) -> None:
        """The vehicle left the edge at ``place``: its running actions stop (FINISHED), unstarted ones FAILED."""
        for run in list(self.runs.values()):
            if run.scope is ActionScope.EDGE and run.place == place and not run.status.final:
                if run.status is RUNNING:
                    self._out.append(Interrupt(run.id))
                    self.set(run, FINISHED)
                else:
                    self.set(run, FAILED)

    def cancel(self) -> None:
        """cancelOrder (§6.6.3, Figure 9): waiting actions FAILED, running ones that can be interrupted too;
        the others run on and report what they end with."""
        for run in list(self.runs.values()):
            if not run.of_order or run.status.final:
                continue
            if run.status is WAITING:
                self.set(run, FAILED)
            elif run.interruptible:
                self._out.append(Interrupt(run.id))
                self.set(run, FAILED)

    def halt(self) -> None:
        """The body stopped for good: whatever has not ended fails (no report of it follows)."""
        for run in list(self.runs.values()):
            if not run.status.final and (run.of_order or run.status is RUNNING):
                self.set(run, FAILED)

    # --- any action -------------------------------------------------------------------------------------

    def hold(self, held: bool) -> None:
        """The vehicle is paused or broken down (``held``), or goes on: running actions are paused with it."""
        for run in self.runs.values():
            if run.status is RUNNING and run.held != held:
                run.held = held
                self._states = None
                if self._report_paused:
                    self._out.append(ActionChanged(run.id, run.action.action_type, PAUSED if held else RUNNING))

    def instant_blocking(self) -> bool:
        """A SOFT or HARD instant action runs: the vehicle must not drive meanwhile. Not a cancelOrder, whatever
        its blocking type: Figure 9 says how the vehicle stops (to the next node, or at once), and holding it
        short of its node would keep the cancel from ever finishing (docs/vda5050.md)."""
        for r in self.runs.values():
            if not r.of_order and r.status is RUNNING and r.blocking is not NONE \
                    and r.action.action_type != "cancelOrder":
                return True
        return False

    def set(self, run: Run, status: ActionStatus, result: str | None = None) -> None:
        if status.final:
            if run in self._queue:
                self._queue.remove(run)
            run.held = False
        run.status = status
        if result is not None:
            run.result = result
        self._states = None
        self._report(run)

    def start(self, run: Run) -> None:
        """The body performs ``run`` now."""
        self.set(run, RUNNING)
        self._out.append(Act(run.action.action_type, run.id, run.action.action_parameters or ()))

    def _report(self, run: Run) -> None:
        self._out.append(ActionChanged(run.id, run.action.action_type, run.status))
