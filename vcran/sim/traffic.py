"""Safety fields in the simulation (docs/contract.md §12): the SimPy side of :class:`vcran.core.traffic.control.Traffic`.

:class:`SafetyFields` decides nothing. The robots' body tells it when a robot starts a leg (:meth:`drive`)
and when it rests without driving on (:meth:`rest`: a leg's end, a hold, a halt, a cancel); it hands each to
the pure :class:`~vcran.core.traffic.control.Traffic` and carries out the effects that come back, in order:

- ``Predicted`` and ``Wake``: an event at the instant (priority COMPLETION, like a leg's end and a collision's
  first contact: docs/contract.md §5), which hands the change back (``due``, ``braked``, ``overdue``); a stale prediction
  costs a no-op there;
- ``Brake``: :meth:`Body.brake` -- the running leg ends now and the braked stretch is driven; the motion is
  not done, the robot waits for ``DriveOn``;
- ``DriveOn``: :meth:`Body.drive_on` -- drive the rest of the motion from rest; its end completes it (the
  body does not report that leg with :meth:`drive`: Traffic gave it);
- ``BlockedBy``, ``Unblocked``, ``Deadlocked``: the events ``blocked`` (naming the robot that entered, and
  where the blocked one was), ``unblocked`` (with how long it was blocked) and ``deadlock`` (on the first
  robot in fleet order, naming the others and the kind), and each protocol's way of showing them
  (:class:`Signals`: OPIL a ``ran_error`` warning, VDA 5050 ``safetyState.fieldViolation``). With
  ``on_deadlock = "cancel"`` every deadlocked robot is told to :meth:`Signals.cancel` its work (reason
  ``deadlock``); its body then rests.

The body (:class:`vcran.sim.body.Body`) calls :meth:`drive` as it starts a leg and when a held leg resumes,
:meth:`rest` when a leg ends with nothing after it, on a hold, a halt or an abandon; ``brake`` and
``drive_on`` interrupt its driving process (docs/robots.md, "Traffic", says what a hold does to a block).

It also keeps the figures the summary gives (:meth:`figures`): each robot's blocks and blocked time (a spell
still open at the end counts up to it) and the fleet's deadlocks. A body's calls may come while effects are
being applied (a protocol that halts a robot at once): they queue behind them, so effects are carried out in
the order Traffic returned them.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Sequence
from typing import Any, Protocol

import simpy

from vcran.core.collisions import Footprint
from vcran.core.events import Event
from vcran.core.incidents import Blocked, Deadlock, Unblocked
from vcran.core.motion import Leg
from vcran.core.scenario import Scenario
from vcran.core.traffic import control
from vcran.core.traffic.braking import Braking
from vcran.core.traffic.control import BRAKED, Effect, Pose, Traffic
from vcran.core.traffic.deadlock import BOUND
from vcran.core.traffic.fields import Field
from vcran.sim.timing import COMPLETION, at

CANCEL = "cancel"


class Body(Protocol):
    """What safety fields ask of one robot's body (the shared body of issue 30, or a test's)."""

    def brake(self, braking: Braking) -> None:
        """Now: end the running leg where it is (``FleetKinematics.stop``) and drive ``braking.stop`` if not
        None (to ``braking.t_stop``); the motion is not done: wait for :meth:`drive_on`."""

    def drive_on(self, leg: Leg) -> None:
        """Now (at or after the braking's end): drive ``leg``, the rest of the braked motion; its end
        completes the motion as the braked leg's would have."""


class Signals(Protocol):
    """How a protocol shows traffic to its fleet manager (docs/contract.md §12). Robots are fleet indices."""

    def blocked(self, robot: int, other: int) -> None:
        """``other`` entered ``robot``'s empty field (OPIL: a ``ran_error`` warning; VDA 5050:
        ``fieldViolation`` true). The body brakes by itself."""

    def unblocked(self, robot: int) -> None:
        """``robot`` is no longer blocked (VDA 5050: ``fieldViolation`` false)."""

    def cancel(self, robot: int, others: Sequence[int]) -> None:
        """``on_deadlock = "cancel"``: end ``robot``'s task with reason ``deadlock`` (``others``: the robots it is
        deadlocked with: the rest of its cycle, or those in its field); its body stops and rests
        (:meth:`SafetyFields.rest`)."""


class SafetyFields:
    """The fleet's safety fields in simulated time (module docstring). ``log(robot, event)`` writes an event
    of robot ``robot`` (a fleet index); ``cancel``: deadlocked robots' tasks are cancelled (else the run goes
    on). Attach each robot's body (:meth:`attach`) and, once, the protocol's :attr:`signals`."""

    def __init__(self, env: simpy.Environment, traffic: Traffic, ids: Sequence[str],
                 log: Callable[[int, Event], None], cancel: bool = False) -> None:
        self.env, self.traffic, self.ids, self._log, self.cancel = env, traffic, list(ids), log, cancel
        n = len(self.ids)
        self.bodies: list[Body | None] = [None] * n
        self.signals: Signals | None = None
        self.blocks = [0] * n
        self._blocked_time = [0.0] * n
        self._since: dict[int, float] = {}  # blocked robots: since when
        self.deadlocks = 0
        self._queue: deque[Effect] = deque()
        self._applying = False

    @classmethod
    def of(cls, env: simpy.Environment, scenario: Scenario, log: Callable[[int, Event], None]) -> SafetyFields | None:
        """The scenario's fields (None when no robot has one: nothing to do, nothing scheduled). A robot
        brakes at its ``max_deceleration`` (0: it stops at once) and its field's braking term uses it."""
        if not scenario.traffic.any_field(scenario.robots):
            return None
        robots = scenario.robots
        fields: list[Field | None] = []
        for r in robots:
            spec = scenario.traffic.field_of(r)
            fields.append(None if spec is None else Field.of(spec, r.footprint, r.max_deceleration))
        traffic = Traffic([Footprint(r.footprint) for r in robots], [r.pose for r in robots], fields,
                          [r.max_deceleration for r in robots], scenario.settings.collision_resolution,
                          scenario.traffic.deadlock_bound)
        return cls(env, traffic, [r.id for r in robots], log, scenario.traffic.on_deadlock == CANCEL)

    def attach(self, robot: int, body: Body) -> None:
        self.bodies[robot] = body

    # --- the body's calls -----------------------------------------------------------------------------------

    def drive(self, robot: int, leg: Leg) -> None:
        """Robot ``robot`` starts ``leg`` now (a motion's leg, or a held leg resumed; not one :meth:`Body.drive_on`
        gave it)."""
        self._apply(self.traffic.drive(robot, leg, self.env.now))

    def rest(self, robot: int, pose: Pose) -> None:
        """Robot ``robot`` rests at ``pose`` from now and does not drive on (a leg's end, a hold, a halt, a
        cancel; not the end of a braked stretch)."""
        self._apply(self.traffic.rest(robot, pose, self.env.now))

    def blocked(self, robot: int) -> bool:
        return self.traffic.blocked(robot)

    # --- the summary ----------------------------------------------------------------------------------------

    def blocked_time(self, robot: int) -> float:
        """Seconds ``robot`` has been blocked so far (a spell still open counts up to now)."""
        since = self._since.get(robot)
        return self._blocked_time[robot] + (self.env.now - since if since is not None else 0.0)

    def figures(self) -> dict[str, Any]:
        """The summary's ``traffic`` section: the fleet's blocks, blocked time and deadlocks."""
        return {"blocks": sum(self.blocks), "blocked_time": sum(self.blocked_time(i) for i in range(len(self.ids))),
                "deadlocks": self.deadlocks}

    def summarise(self, summary: dict[str, Any]) -> None:
        """Add docs/contract.md §12's figures to ``summary`` (summary.json, docs/outputs.md): each robot's ``blocks`` and
        ``blocked_time``, and the fleet's ``traffic`` section (:meth:`figures`)."""
        robots = summary["robots"]
        for i, rid in enumerate(self.ids):
            robots[rid]["blocks"] = self.blocks[i]
            robots[rid]["blocked_time"] = self.blocked_time(i)
        summary["traffic"] = self.figures()

    # --- effects --------------------------------------------------------------------------------------------

    def _apply(self, effects: list[Effect]) -> None:
        self._queue.extend(effects)
        if self._applying:
            return  # a body's call made while effects are carried out: after them, in order
        self._applying = True
        try:
            while self._queue:
                self._effect(self._queue.popleft())
        finally:
            self._applying = False

    def _effect(self, e: Effect) -> None:
        now = self.env.now
        if isinstance(e, control.Predicted):
            change = e.change
            at(self.env, change.t, COMPLETION).callbacks.append(
                lambda _: self._apply(self.traffic.due(change, self.env.now)))
        elif isinstance(e, control.Wake):
            self._wake(e)
        elif isinstance(e, control.Brake):
            self._body(e.robot).brake(e.braking)
        elif isinstance(e, control.DriveOn):
            self._body(e.robot).drive_on(e.leg)
        elif isinstance(e, control.BlockedBy):
            i, other = e.robot, e.other
            self.blocks[i] += 1
            self._since.setdefault(i, now)
            x, y = self._where(i, now)
            self._log(i, Blocked(self.ids[other], x, y))
            if self.signals is not None:
                self.signals.blocked(i, other)
        elif isinstance(e, control.Unblocked):
            i = e.robot
            since = self._since.pop(i, now)
            self._blocked_time[i] += now - since
            self._log(i, Unblocked(now - since))
            if self.signals is not None:
                self.signals.unblocked(i)
        else:
            self._deadlock(e)

    def _wake(self, w: control.Wake) -> None:
        robot, spell = w.robot, w.spell
        if w.kind == BRAKED:
            def call(_: object) -> None:
                self._apply(self.traffic.braked(robot, spell, self.env.now))
        else:
            def call(_: object) -> None:
                self._apply(self.traffic.overdue(robot, self.env.now))
        at(self.env, w.t, COMPLETION).callbacks.append(call)

    def _deadlock(self, e: control.Deadlocked) -> None:
        d = e.deadlock
        self.deadlocks += 1
        first = d.robots[0]
        others = d.waiting_for if d.kind == BOUND else d.robots[1:]
        spell = self.env.now - self._since.get(first, self.env.now)  # how long ``first`` has been blocked
        self._log(first, Deadlock(d.kind, ", ".join(self.ids[r] for r in others), spell))
        if self.cancel and self.signals is not None:
            for r in d.robots:
                self.signals.cancel(r, [o for o in (*d.robots, *d.waiting_for) if o != r])

    def _body(self, robot: int) -> Body:
        body = self.bodies[robot]
        assert body is not None, f"robot {robot} has no body attached"
        return body

    def _where(self, robot: int, now: float) -> tuple[float, float]:
        track = self.traffic.watch.tracks[robot]
        if track.leg is not None:
            x, y, *_ = track.leg.pose_at(now)
            return float(x), float(y)
        return float(track.pose[0]), float(track.pose[1])
