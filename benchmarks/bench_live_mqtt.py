"""VDA 5050 live over MQTT: does ``vcran live --mqtt`` keep up with 100 vehicles at 1 Hz state and
visualization at ``--factor 10`` (issue 31's must-show; docs/vda5050.md, "Live over MQTT")?

    python benchmarks/bench_live_mqtt.py                       # 100 vehicles, x10, 45 wall seconds of orders
    python benchmarks/bench_live_mqtt.py --vehicles 50 --factor 4 --seconds 30
    python benchmarks/bench_live_mqtt.py --seconds 30 --profile live.prof   # where vcran live's time goes

Against a Mosquitto on a free loopback port (tests/transports/mqtt/mosquitto.py): a generated VDA 5050
scenario (vehicles 5 m apart on a grid, ``telemetry_period = 1`` so visualization is 1 Hz, ``[simulation]
state_interval = 1`` so an idle vehicle's state is 1 Hz too) runs as ``vcran live SCENARIO --mqtt URL --factor
F --out DIR``, its own process. This process is the master, a plain paho client (not vcran's code): it
subscribes to every vehicle's state, visualization and connection, waits until all are ONLINE, then for
``--seconds`` wall seconds sends each vehicle, a random 1 to 3 wall seconds after its last order finished, an
order 1 m along x and back (two nodes, one edge, from where it stands). It measures

- messages received per wall second, by topic, against the periodic floor: vehicles x 2 topics x 1 Hz x F
  (states on events come on top);
- whether the simulation keeps up: simulated seconds gained per wall second over the window, read off the
  states' timestamps (simulated time on the run's calendar, whose epoch is ONLINE's timestamp), which is F
  when it does; each state's lag, its arrival against the wall instant its stamp stands for (epoch +
  simulated / F; the simulation's start after the epoch is the same in all, so the quickest is taken as 0),
  which grows over the window when it does not; and the live run's own figures at its end (its simulated
  time, wall time, messages/s, CPU);
- the ``vcran live`` process's CPU over the window (/proc/PID/stat utime + stime), and Mosquitto's; how long
  its main thread, the simulation's, waited for a CPU while runnable (/proc/PID/schedstat), which is what a
  loaded machine takes from it;
- latency from the master's publish of an order to the first state carrying its orderId (median, p99);
  ``vcran live``'s own arrival-to-state figure is printed beside it.

It ends the run with SIGTERM (its normal end: OFFLINE, outputs completed, exit 0) and prints a Markdown table.
"""

from __future__ import annotations

import argparse
import os
import random
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
TICK = os.sysconf("SC_CLK_TCK")


def scenario(vehicles: int, state_interval: float) -> str:
    """``vehicles`` VDA 5050 vehicles on a grid 5 m apart (a 1 m move meets nobody), no script, an hour long
    (the benchmark ends the run first)."""
    side = max(1, round(vehicles ** 0.5))
    parts = ["[simulation]", 'name = "bench-live-mqtt"', 'protocol = "vda5050"', "duration = 36000.0",
             "telemetry_period = 1.0", f"state_interval = {state_interval}", ""]
    for i in range(vehicles):
        parts += ["[[robots]]", f'id = "v{i:03d}"', 'manufacturer = "bench"', f'serial_number = "V{i:03d}"',
                  f"pose = [{5.0 * (i % side)}, {5.0 * (i // side)}, 0.0]", ""]
    return "\n".join(parts)


def cpu_of(pid: int) -> float:
    """CPU seconds (user + system) of process ``pid`` so far."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICK


def waited(pid: int) -> float:
    """Seconds the main thread of process ``pid`` (the simulation's) spent runnable but waiting for a CPU
    (/proc/PID/schedstat's second field): what the machine's other processes took from it."""
    return int(Path(f"/proc/{pid}/schedstat").read_text().split()[1]) / 1e9


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def stamp_seconds(text: str) -> float:
    return datetime.fromisoformat(text).timestamp()


@dataclass
class Vehicle:
    serial: str
    x: float
    y: float
    n: int = 0  # orders sent
    header_id: int = 0
    order_id: str | None = None  # the order running, None when free
    next_at: float = 0.0  # wall (monotonic) time of its next order


@dataclass
class Master:
    """The benchmark's VDA 5050 master: what it sent and when, what it got."""

    vehicles: dict[str, Vehicle]
    factor: float
    counting: bool = False
    counts: dict[str, int] = field(default_factory=lambda: {"state": 0, "visualization": 0, "connection": 0})
    online: set[str] = field(default_factory=set)
    epoch: float | None = None  # the run's calendar: ONLINE's timestamp is simulated 0
    sent_at: dict[str, float] = field(default_factory=dict)  # orderId -> monotonic publish time
    latencies: list[float] = field(default_factory=list)
    completed: int = 0
    rejected: int = 0
    last_sim: float = 0.0  # the latest simulated time a state carried
    #: Per state in the window: wall arrival minus the wall instant its stamp stands for (epoch + sim / factor);
    #: the simulation's start after the epoch is a constant in it, so its spread is the delivery's lag.
    lags: list[float] = field(default_factory=list)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def on_message(self, _client: Any, _userdata: Any, message: Any) -> None:
        import orjson

        now = time.monotonic()
        _, _, _, serial, kind = message.topic.split("/")
        if self.counting:
            self.counts[kind] += 1
        if kind == "visualization":
            return
        doc = orjson.loads(message.payload)
        with self.lock:
            if kind == "connection":
                if doc["connectionState"] == "ONLINE":
                    self.online.add(serial)
                    self.epoch = stamp_seconds(doc["timestamp"])
                return
            if self.epoch is not None:
                sim = stamp_seconds(doc["timestamp"]) - self.epoch
                self.last_sim = max(self.last_sim, sim)
                if self.counting:
                    self.lags.append(time.time() - (self.epoch + sim / self.factor))
            order_id = doc["orderId"]
            sent = self.sent_at.pop(order_id, None)
            if sent is not None:
                self.latencies.append(now - sent)
            v = self.vehicles[serial]
            if v.order_id is None or order_id != v.order_id:
                return
            if any(e.get("errorType") in ("orderError", "orderUpdateError", "validationError", "noRouteError")
                   for e in doc["errors"]):
                self.rejected += 1
                v.order_id, v.next_at = None, now + 1.0
            elif not doc["nodeStates"] and not doc["edgeStates"] and not doc["driving"]:
                pos = doc.get("agvPosition") or {}
                v.x, v.y = pos.get("x", v.x), pos.get("y", v.y)
                self.completed += 1
                v.order_id, v.next_at = None, now + random.uniform(1.0, 3.0)

    def order(self, client: Any, v: Vehicle, now: float) -> None:
        """A 1 m move along +x, or back along -x every other time, from where the vehicle stands (§6.6.2)."""
        import orjson

        dx = 1.0 if v.n % 2 == 0 else -1.0
        order_id = f"{v.serial}-{v.n}"
        body = {
            "headerId": v.header_id, "timestamp": datetime.now(UTC).isoformat(timespec="milliseconds")[:-6] + "Z",
            "version": "2.1.0", "manufacturer": "bench", "serialNumber": v.serial,
            "orderId": order_id, "orderUpdateId": 0,
            "nodes": [
                {"nodeId": f"{order_id}-a", "sequenceId": 0, "released": True, "actions": [],
                 "nodePosition": {"x": v.x, "y": v.y, "mapId": "map"}},
                {"nodeId": f"{order_id}-b", "sequenceId": 2, "released": True, "actions": [],
                 "nodePosition": {"x": v.x + dx, "y": v.y, "mapId": "map"}},
            ],
            "edges": [{"edgeId": f"{order_id}-e", "sequenceId": 1, "released": True, "startNodeId": f"{order_id}-a",
                       "endNodeId": f"{order_id}-b", "actions": []}],
        }
        v.header_id += 1
        v.n += 1
        v.order_id = order_id
        with self.lock:
            self.sent_at[order_id] = now
        client.publish(f"uagv/v2/bench/{v.serial}/order", orjson.dumps(body), qos=0)


def figures(text: str) -> dict[str, str]:
    """The live run's end-of-run lines, by what they start with."""
    import re

    out: dict[str, str] = {}
    if m := re.search(r"live run ended at ([\d.]+) s simulated", text):
        out["sim"] = m.group(1)
    if m := re.search(r"wall ([\d.]+) s, out ([\d.]+) messages/s .*?in ([\d.]+) messages/s .*?cpu ([\d.]+) s", text):
        out["wall"], out["out_rate"], out["in_rate"], out["cpu"] = m.groups()
    if m := re.search(r"arrival to the state it caused: median ([\d.]+) ms, p99 ([\d.]+) ms", text):
        out["answer_median"], out["answer_p99"] = m.groups()
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--vehicles", type=int, default=100)
    parser.add_argument("--factor", type=float, default=10.0)
    parser.add_argument("--seconds", type=float, default=45.0, help="wall seconds of orders, measured")
    parser.add_argument("--state-interval", type=float, default=1.0)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--profile", metavar="FILE", type=Path,
                        help="run vcran live under cProfile (its main thread, the simulation's), stats into FILE")
    args = parser.parse_args()
    sys.path.insert(0, str(ROOT))
    random.seed(args.seed)
    import paho.mqtt.client as mqtt
    from paho.mqtt.enums import CallbackAPIVersion

    from tests.transports.mqtt.mosquitto import Mosquitto

    load = os.getloadavg()
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        broker = Mosquitto(work)
        broker.start()
        assert broker.process is not None
        broker_pid = broker.process.pid
        live = None
        try:
            path = work / "fleet.toml"
            path.write_text(scenario(args.vehicles, args.state_interval))
            side = max(1, round(args.vehicles ** 0.5))
            master = Master({f"V{i:03d}": Vehicle(f"V{i:03d}", 5.0 * (i % side), 5.0 * (i // side))
                             for i in range(args.vehicles)}, args.factor)
            client = mqtt.Client(CallbackAPIVersion.VERSION2, client_id="bench-master")
            subscribed = threading.Event()
            client.on_connect = lambda c, *_: c.subscribe([(f"uagv/v2/+/+/{t}", 0)
                                                           for t in ("state", "visualization", "connection")])
            client.on_subscribe = lambda *_: subscribed.set()
            client.on_message = master.on_message
            client.max_queued_messages_set(0)
            client.connect("127.0.0.1", broker.port)
            client.loop_start()
            assert subscribed.wait(10), "the master could not subscribe"
            env = {**os.environ, "PYTHONUNBUFFERED": "1"}
            log_out, log_err = (work / "live.out").open("w"), (work / "live.err").open("w")
            started = time.monotonic()
            profiled = ["-m", "cProfile", "-o", str(args.profile.resolve())] if args.profile else []
            live = subprocess.Popen([sys.executable, *profiled, "-m", "vcran", "live", str(path), "--mqtt", broker.url,
                                     "--factor", f"{args.factor:g}", "--out", str(work / "run")],
                                    stdout=log_out, stderr=log_err, stdin=subprocess.DEVNULL, env=env, cwd=ROOT)
            deadline = time.monotonic() + 120
            while len(master.online) < args.vehicles:
                if live.poll() is not None or time.monotonic() > deadline:
                    raise RuntimeError(f"vcran live: {len(master.online)} of {args.vehicles} ONLINE; "
                                       f"{(work / 'live.err').read_text()[-2000:]}")
                time.sleep(0.05)
            online_after = time.monotonic() - started
            time.sleep(2.0)  # the simulation starts once the fleet is connected and built
            # The window: messages counted, orders sent, CPU read at both ends.
            with master.lock:
                sim0 = master.last_sim
            live_cpu0, broker_cpu0, own0 = cpu_of(live.pid), cpu_of(broker_pid), time.process_time()
            waited0 = waited(live.pid)
            master.counting = True
            t0 = time.monotonic()
            for v in master.vehicles.values():
                v.next_at = t0 + random.uniform(0.0, 2.0)
            while (now := time.monotonic()) < t0 + args.seconds:
                for v in master.vehicles.values():
                    if v.order_id is None and v.next_at <= now:
                        master.order(client, v, now)
                time.sleep(0.02)
            master.counting = False
            wall = time.monotonic() - t0
            live_cpu = cpu_of(live.pid) - live_cpu0
            live_waited = waited(live.pid) - waited0
            broker_cpu = cpu_of(broker_pid) - broker_cpu0
            own = time.process_time() - own0
            with master.lock:
                sim1, latencies, lags = master.last_sim, list(master.latencies), list(master.lags)
                counts, sent = dict(master.counts), sum(v.n for v in master.vehicles.values())
                completed, rejected, unanswered = master.completed, master.rejected, len(master.sent_at)
            live.send_signal(signal.SIGTERM)
            code = live.wait(120)
            log_out.close()
            log_err.close()
            text = (work / "live.out").read_text()
            client.disconnect()
            client.loop_stop()
        finally:
            if live is not None and live.poll() is None:
                live.kill()
                live.wait()
            broker.stop()
    ran = figures(text)
    floor = args.vehicles * (1.0 / args.state_interval + 1.0) * args.factor
    total = counts["state"] + counts["visualization"]
    gained = (sim1 - sim0) / wall
    rows = [
        ("vehicles, factor", f"{args.vehicles}, x{args.factor:g}"),
        ("all ONLINE after", f"{online_after:.1f} s wall"),
        ("window", f"{wall:.1f} s wall"),
        ("messages/s received (state + visualization)",
         f"{total / wall:.0f} ({counts['state'] / wall:.0f} + {counts['visualization'] / wall:.0f}); periodic floor "
         f"{floor:.0f}"),
        ("simulated s per wall s over the window", f"{gained:.2f} (x{args.factor:g} keeps up: "
                                                   f"{'yes' if gained >= 0.98 * args.factor else 'NO'})"),
        ("state lag beyond the quickest (arrival against its stamp's wall instant)",
         f"median {(statistics.median(lags) - min(lags)) * 1000:.0f} ms, p99 "
         f"{(percentile(lags, 0.99) - min(lags)) * 1000:.0f} ms; first tenth of the window "
         f"{(statistics.median(lags[:len(lags) // 10]) - min(lags)) * 1000:.0f} ms, last tenth "
         f"{(statistics.median(lags[-len(lags) // 10:]) - min(lags)) * 1000:.0f} ms" if len(lags) >= 10 else "-"),
        ("vcran live CPU over the window", f"{live_cpu:.1f} s, {live_cpu / wall * 100:.0f}% of one core"),
        ("vcran live's simulation thread waiting for a CPU (runnable) over the window",
         f"{live_waited:.1f} s, {live_waited / wall * 100:.0f}% of the window"),
        ("Mosquitto CPU over the window", f"{broker_cpu:.1f} s, {broker_cpu / wall * 100:.0f}% of one core"),
        ("master (this process) CPU", f"{own:.1f} s, {own / wall * 100:.0f}% of one core"),
        ("orders sent, completed, rejected, unanswered at the end (in flight)", f"{sent}, {completed}, {rejected}, {unanswered}"),
        ("order publish to first state with its orderId",
         f"median {statistics.median(latencies) * 1000:.0f} ms, p99 {percentile(latencies, 0.99) * 1000:.0f} ms "
         f"({len(latencies)} orders)" if latencies else "no order answered"),
        ("vcran live: arrival to the state it caused",
         f"median {ran.get('answer_median', '?')} ms, p99 {ran.get('answer_p99', '?')} ms"),
        ("vcran live at its end", f"{ran.get('sim', '?')} s simulated in {ran.get('wall', '?')} s wall; out "
                                  f"{ran.get('out_rate', '?')} messages/s, in {ran.get('in_rate', '?')}; cpu "
                                  f"{ran.get('cpu', '?')} s; exit {code}"),
        ("load average at start (1, 5, 15 min)", ", ".join(f"{x:.2f}" for x in load)),
    ]
    print("| measure | value |\n|---|---|")
    for name, value in rows:
        print(f"| {name} | {value} |")
    return 0 if code == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
