"""What the MQTT edge's tests drive it with: a raw paho client watching the broker (not vcran's code); a
miniature of the simulation's side (a LiveEnvironment and a tiny process per vehicle publishing what the
VDA 5050 glue publishes: factsheet at start, then state and visualization every ``period``); and the whole
of it, ``vcran live SCENARIO --mqtt URL`` as its own process (:class:`LiveRun`), as a user starts it."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import orjson
import paho.mqtt.client as mqtt
from paho.mqtt.enums import CallbackAPIVersion

from transports.mqtt import FleetVehicle, MqttTransport
from vcran.core.vda5050.config import VehicleConfig
from vcran.core.vda5050.effects import Body, Where
from vcran.core.vda5050.enums import Version
from vcran.core.vda5050.vehicle import Vehicle
from vcran.core.wire import Inbound, Publish
from vcran.sim.live import LiveEnvironment


def wait_until(predicate: Callable[[], Any], timeout: float = 20.0, step: float = 0.02) -> bool:
    """Poll ``predicate`` until it is true or ``timeout`` wall seconds have passed (a wait, never a measure)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(step)
    return bool(predicate())


@dataclass(frozen=True)
class Seen:
    topic: str
    payload: bytes
    qos: int
    retain: bool
    #: When it arrived, on the wall clock (time.time(): the calendar a master reads timestamps against).
    received: float = 0.0

    @property
    def doc(self) -> Any:
        return orjson.loads(self.payload)

    @property
    def kind(self) -> str:
        return self.topic.rsplit("/", 1)[1]


class Watcher:
    """A plain paho client subscribed to ``filters`` at QoS 1 (so a message arrives with its publisher's QoS),
    re-subscribing after each reconnect; everything it gets is kept in order."""

    def __init__(self, url: str, filters: tuple[str, ...] = ("#",)) -> None:
        host, port = url.removeprefix("mqtt://").rsplit(":", 1)
        self.seen: list[Seen] = []
        self.subscribed = threading.Event()
        self._lock = threading.Lock()
        self._filters = filters
        self.client = mqtt.Client(CallbackAPIVersion.VERSION2, client_id=f"watcher-{id(self)}")
        self.client.reconnect_delay_set(0.05, 0.2)  # type: ignore[arg-type]
        self.client.on_connect = lambda c, *_: c.subscribe([(f, 1) for f in self._filters])
        self.client.on_subscribe = lambda *_: self.subscribed.set()
        self.client.on_disconnect = lambda *_: self.subscribed.clear()
        self.client.on_message = self._message
        self.client.connect_async(host, int(port), keepalive=15)
        self.client.loop_start()
        assert self.subscribed.wait(10), "the watcher could not subscribe"

    def _message(self, _client: Any, _userdata: Any, message: mqtt.MQTTMessage) -> None:
        with self._lock:
            self.seen.append(Seen(message.topic, message.payload, message.qos, bool(message.retain), time.time()))

    def of(self, kind: str | None = None, topic: str | None = None) -> list[Seen]:
        with self._lock:
            return [s for s in self.seen if (kind is None or s.kind == kind) and (topic is None or s.topic == topic)]

    def publish(self, topic: str, payload: bytes) -> None:
        self.client.publish(topic, payload, qos=0).wait_for_publish(10)

    def close(self) -> None:
        self.client.disconnect()
        self.client.loop_stop()


def retained(url: str, topics: tuple[str, ...]) -> dict[str, Seen]:
    """What a newcomer gets on subscribing to ``topics``: the retained messages. The last topic must hold one:
    the broker sends retained messages filter by filter after the SUBACK, so once the last one's arrives,
    the others' have arrived or do not exist (no waiting on the clock)."""
    watcher = Watcher(url, topics)
    try:
        assert wait_until(lambda: any(s.retain for s in watcher.of(topic=topics[-1]))), f"nothing retained on {topics[-1]}"
        return {s.topic: s for s in watcher.of() if s.retain}  # live messages meanwhile are not what was retained
    finally:
        watcher.close()


def config(serial: str, version: Version = Version.V2_1_0, manufacturer: str = "vcran") -> VehicleConfig:
    return VehicleConfig(manufacturer=manufacturer, serial_number=serial, version=version)


@dataclass
class Driver:
    """The simulation thread of a live run in miniature, on ``transport`` at ``speed`` simulated seconds per
    wall second. Each vehicle's logic (vcran's pure Vehicle: it stamps the headers) publishes its factsheet
    at start, then state and visualization every ``period``; what the transport delivers is kept with the
    simulated time it entered at."""

    transport: MqttTransport
    configs: dict[str, VehicleConfig]
    speed: float = 10.0
    period: float = 1.0
    delivered: list[tuple[float, Inbound]] = field(default_factory=list)
    #: (robot, topic, headerId, simulated time, whether the robot's connection was up) of each publish
    produced: list[tuple[str, str, int, float, bool]] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.env = LiveEnvironment(self.speed)
        self.logic = {robot: Vehicle(cfg) for robot, cfg in self.configs.items()}
        self._done = self.env.event()
        self._thread = threading.Thread(target=self._run, name="sim", daemon=True)
        self.error: BaseException | None = None

    @staticmethod
    def fleet(configs: dict[str, VehicleConfig]) -> list[FleetVehicle]:
        return [FleetVehicle.of(robot, cfg) for robot, cfg in configs.items()]

    def start(self) -> Driver:
        self.transport.attach(self.env, lambda inbound: self.delivered.append((self.env.now, inbound)))
        for robot in self.configs:
            self.env.process(self._vehicle(robot))
        self._thread.start()
        return self

    def stop(self) -> None:
        """End the run at the next instant, then close the transport as the runner does."""
        self.env.call_soon(lambda: self._done.succeed() if not self._done.triggered else None)
        self._thread.join(30)
        assert not self._thread.is_alive(), "the simulation did not stop"
        self.transport.close()
        if self.error is not None:
            raise self.error

    def count(self, topic: str, *, up: bool | None = None) -> int:
        return sum(1 for p in list(self.produced) if p[1] == topic and (up is None or p[4] == up))

    def _run(self) -> None:
        try:
            self.env.run(until=self._done)
        except BaseException as exc:  # noqa: BLE001 - re-raised in the test thread by stop()
            self.error = exc

    def _vehicle(self, robot: str):
        logic, env = self.logic[robot], self.env
        self._send(robot, "factsheet", logic.factsheet(env.now))
        while True:
            body = Body(Where(env.now, 0.0, 0.0), vx=1.0)
            self._send(robot, "state", logic.state(env.now, body))
            self._send(robot, "visualization", logic.visualization(env.now, body))
            yield env.timeout(self.period)

    def _send(self, robot: str, topic: str, message: Any) -> None:
        up = self.transport.client(robot).up
        self.produced.append((robot, topic, message.header.header_id, self.env.now, up))
        self.transport.send(Publish(self.env.now, robot, topic, message))


def vehicle_scenario(folder: Path, serial: str, *, version: str = "2.1.0", manufacturer: str = "vcran") -> Path:
    """A scenario file of one VDA 5050 vehicle, robot ``agv1``, standing at (0, 0) facing +x with nothing
    else on the floor (no station, no other robot): free space for orders along +x. It drives at 1 m/s at
    most, accelerating and braking at 0.5 m/s²; it runs for an hour unless stopped."""
    path = folder / f"{manufacturer}-{serial}.toml"
    path.write_text(f"""[simulation]
name = "live-{serial}"
seed = 1
protocol = "vda5050"
duration = 3600.0

[[robots]]
id = "agv1"
manufacturer = "{manufacturer}"
serial_number = "{serial}"
version = "{version}"
pose = [0.0, 0.0, 0.0]
max_velocity = 1.0
max_acceleration = 0.5
""")
    return path


class LiveRun:
    """``vcran live SCENARIO --mqtt URL --out OUT --factor F`` as its own process; :meth:`wait_online` returns
    once the broker holds the retained ONLINE of each vehicle named (``uagv/v2/<manufacturer>/<serial>``),
    :meth:`stop` sends SIGTERM (the normal end of a live run) and returns its exit status and output."""

    def __init__(self, url: str, scenario: Path | str, out: Path, *, factor: float = 1.0) -> None:
        self.url, self.out = url, out
        env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        self.process = subprocess.Popen(
            [sys.executable, "-m", "vcran", "live", str(scenario), "--mqtt", url, "--out", str(out),
             "--factor", f"{factor:g}"],
            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True)
        self.result: tuple[int, str, str] | None = None

    def wait_online(self, *vehicles: str, timeout: float = 30.0) -> None:
        watcher = Watcher(self.url, tuple(f"{v}/connection" for v in vehicles))
        try:
            def online() -> bool:
                shown = {s.topic: s.doc.get("connectionState") for s in watcher.of("connection")}
                return all(shown.get(f"{v}/connection") == "ONLINE" for v in vehicles) or self.process.poll() is not None

            assert wait_until(online, timeout), f"no retained ONLINE of {vehicles} within {timeout} s"
            assert self.process.poll() is None, f"vcran live exited with {self.process.returncode}: {self.stop()}"
        finally:
            watcher.close()

    def stop(self) -> tuple[int, str, str]:
        """SIGTERM, then the exit status, stdout and stderr; a process that does not end in time is killed."""
        if self.result is None:
            if self.process.poll() is None:
                self.process.send_signal(signal.SIGTERM)
            try:
                out, err = self.process.communicate(timeout=30)
            except subprocess.TimeoutExpired:
                self.process.kill()
                out, err = self.process.communicate()
            self.result = (self.process.returncode, out, err)
        return self.result
