"""The shared closed-loop machinery without OPIL (issue 30 item 5): a second protocol's manager and handle sit
beside OPIL's on :class:`vcran.sim.loop.Loop` (jobs at their times, timers, the link's latency and
link_down, the hook order) and import nothing of OPIL's."""

from __future__ import annotations

import random
import tomllib
from typing import Any

import simpy

from vcran.core.manager import Handle, Manager
from vcran.core.wire import Inbound, Publish
from vcran.io.scenario_file import parse
from vcran.sim.loop import InSimTime, Loop

FLEET = """
[simulation]
duration = 100.0
seed = 5
[link]
latency = 0.5
[[robots]]
id = "r1"
pose = [0.0, 0.0, 0.0]
[[stations]]
id = "a"
position = [0.0, 0.0]
[[stations]]
id = "b"
position = [4.0, 0.0]
[[jobs]]
t = 2.0
id = "j1"
pickup = "a"
dropoff = "b"
[[jobs]]
t = 7.0
id = "j2"
pickup = "b"
dropoff = "a"
"""


class OrderHandle(InSimTime, Handle):
    """A made-up protocol's handle: it writes an ``order`` topic (a VDA 5050 master's would write orders)."""

    def __init__(self, env: simpy.Environment, loop: Loop, rng: random.Random) -> None:
        super().__init__(loop.fleet, loop.jobs, rng)
        self.env, self._loop = env, loop

    def order(self, robot: str, body: dict[str, Any]) -> None:
        assert self._loop.link is not None
        self._loop.link.write(self._robot(robot), "order", body)


class OrderLoop(Loop):
    periodic = frozenset({"heartbeat"})
    every = frozenset({"error"})

    def make_handle(self, env: simpy.Environment, rng: random.Random) -> OrderHandle:
        return OrderHandle(env, self, rng)

    def notified(self, batch: list[Any]) -> None:
        assert self.handle is not None
        for out in batch:
            self._call("on_state", out.robot, out.attribute, out.message, self.handle.now)


class Master(Manager):
    def __init__(self) -> None:
        self.log: list[tuple[float, str, Any]] = []

    def on_start(self) -> None:
        self.handle.call_at(1.0, lambda: self.log.append((self.handle.now, "timer", None)))

    def on_job(self, job: Any) -> None:
        self.log.append((self.handle.now, "job", job.id))
        self.handle.order("r1", {"job": job.id})
        self.handle.call_later(3.0, self.handle.job_done, job)

    def on_state(self, robot: str, topic: str, message: Any, t: float) -> None:
        self.log.append((t, topic, message))


def run(until: float, down: tuple[float, float] | None = None) -> tuple[Master, OrderLoop, list[tuple[float, Inbound]]]:
    scenario = parse(tomllib.loads(FLEET), "<seam>")
    env = simpy.Environment(0.0)
    master, events = Master(), []
    loop = OrderLoop(scenario, master, lambda t, robot, name, fields: events.append((t, name)))
    delivered: list[tuple[float, Inbound]] = []
    loop.attach(env, lambda inbound: delivered.append((env.now, inbound)))
    if down is not None:
        env.run(until=down[0])
        loop.outage("r1", down[1])
    env.process(publisher(env, loop))
    env.run(until=until)
    return master, loop, delivered


def publisher(env: simpy.Environment, loop: Loop):  # type: ignore[no-untyped-def]
    """The robot's side: a state at 3.0 and an error at 3.5, both to the manager."""
    yield env.timeout(3.0 - env.now)
    loop.send(Publish(env.now, "r1", "state", "driving"))
    yield env.timeout(0.5)
    loop.send(Publish(env.now, "r1", "error", "e1"))


def test_jobs_timers_writes_and_updates_go_through_the_shared_loop_in_order():
    master, loop, delivered = run(20.0)
    # by hand: the timer at 1.0; job j1 at 2.0, its order lands after the link's 0.5 s latency (2.5); the
    # robot's state published at 3.0 reaches the manager at 3.5, its error at 4.0; j2 at 7.0, landing 7.5
    assert master.log == [(1.0, "timer", None), (2.0, "job", "j1"), (3.5, "state", "driving"), (4.0, "error", "e1"),
                          (7.0, "job", "j2")]
    assert [(t, i.entity, i.attribute, i.message) for t, i in delivered] == [
        (2.5, "r1", "order", {"job": "j1"}), (7.5, "r1", "order", {"job": "j2"})]
    # both jobs reported done 3 s after they arrived; nothing left open, no timer pending
    assert [(r.id, r.outcome, r.ended) for r in loop.jobs.records()] == [("j1", "completed", 5.0), ("j2", "completed", 10.0)]
    assert loop.exhausted


def test_link_down_holds_the_protocols_writes_and_publications():
    master, _, delivered = run(20.0, down=(1.5, 6.0))
    # the link of r1 is down from 1.5 to 6.0: j1's order (landed at 2.5) reaches the robot when it is back,
    # and the state and error the robot published meanwhile reach the manager 0.5 s after that
    assert [(t, i.message) for t, i in delivered] == [(6.0, {"job": "j1"}), (7.5, {"job": "j2"})]
    assert [entry for entry in master.log if entry[1] in ("state", "error")] == [(6.5, "state", "driving"),
                                                                                 (6.5, "error", "e1")]
