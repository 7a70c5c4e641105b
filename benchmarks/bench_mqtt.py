"""VDA 5050 over MQTT: what one connection per vehicle costs (transports/mqtt, docs/vda5050.md "Live over MQTT").

    python benchmarks/bench_mqtt.py                 # 100 vehicles, 20 000 state messages
    python benchmarks/bench_mqtt.py --vehicles 300 --messages 50000

Against a Mosquitto on a free loopback port: vcran's MqttTransport connects the fleet (one paho client, so
one network thread and one last will, per vehicle): wall time to connect, threads and resident memory
added, CPU while idle; then the simulation thread's side sends state messages round-robin through the
transport (encoding included), against the same encoded payloads through one shared paho client, the
design VDA 5050's per-vehicle last will rules out. CPU per message is the caller thread's, and the whole
process's (the network threads included), after the last message reached the broker.
"""

from __future__ import annotations

import argparse
import resource
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def rss() -> int:
    return int(Path("/proc/self/statm").read_text().split()[1]) * resource.getpagesize()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--vehicles", type=int, default=100)
    parser.add_argument("--messages", type=int, default=20_000)
    args = parser.parse_args()
    sys.path.insert(0, str(ROOT))
    import paho.mqtt.client as mqtt
    from paho.mqtt.enums import CallbackAPIVersion

    from tests.transports.mqtt.mosquitto import Mosquitto
    from transports.mqtt import FleetVehicle, MqttTransport, parse_url
    from vcran.core.vda5050.codec import encode
    from vcran.core.vda5050.config import VehicleConfig
    from vcran.core.vda5050.effects import Body, Where
    from vcran.core.vda5050.vehicle import Vehicle
    from vcran.core.wire import Publish

    with tempfile.TemporaryDirectory() as folder:
        broker = Mosquitto(Path(folder))
        broker.start()
        try:
            configs = {f"r{i:03d}": VehicleConfig("bench", f"S{i:03d}") for i in range(args.vehicles)}
            logic = {robot: Vehicle(cfg) for robot, cfg in configs.items()}
            transport = MqttTransport(parse_url(broker.url), [FleetVehicle.of(r, c) for r, c in configs.items()])
            threads, memory, c0, t0 = threading.active_count(), rss(), cpu(), time.monotonic()
            transport.open(timeout=60)
            print(f"{args.vehicles} vehicles connected (ONLINE sent) in {time.monotonic() - t0:.3f} s wall, "
                  f"{cpu() - c0:.3f} s CPU; +{threading.active_count() - threads} threads, "
                  f"+{(rss() - memory) / 1e6:.1f} MB resident")
            c0 = cpu()
            time.sleep(5)
            print(f"idle: {(cpu() - c0) / 5 * 100:.2f}% of one core")
            robots = list(configs)
            body = Body(Where(1.0, 2.0, 0.5), vx=1.0)
            messages = [logic[robots[i % len(robots)]].state(i * 0.01, body) for i in range(args.messages)]
            c0, m0 = cpu(), time.thread_time()
            for i, message in enumerate(messages):
                transport.send(Publish(i * 0.01, robots[i % len(robots)], "state", message))
            caller = time.thread_time() - m0
            time.sleep(1.0)  # the network threads finish writing
            total = cpu() - c0  # the sleep costs no CPU
            print(f"per vehicle: {caller / args.messages * 1e6:.0f} µs caller CPU per state (encoding included), "
                  f"{total / args.messages * 1e6:.0f} µs process CPU")
            transport.close()
            payloads = [(f"uagv/v2/bench/{robots[i % len(robots)]}/state", encode(m, configs[robots[0]].version))
                        for i, m in enumerate(messages)]
            up = threading.Event()
            shared = mqtt.Client(CallbackAPIVersion.VERSION2, client_id="bench-shared")
            shared.on_connect = lambda *_: up.set()
            shared.connect_async("127.0.0.1", broker.port)
            shared.loop_start()
            up.wait(10)
            encode_cpu = time.thread_time()
            for m in messages:
                encode(m, configs[robots[0]].version)
            encode_cpu = time.thread_time() - encode_cpu
            c0, m0 = cpu(), time.thread_time()
            for topic, payload in payloads:
                shared.publish(topic, payload, qos=0)
            caller = time.thread_time() - m0
            time.sleep(1.0)
            total = cpu() - c0
            print(f"one shared client: {(caller + encode_cpu) / args.messages * 1e6:.0f} µs caller CPU per state "
                  f"(encoding included), {(total + encode_cpu) / args.messages * 1e6:.0f} µs process CPU")
            shared.disconnect()
            shared.loop_stop()
        finally:
            broker.stop()


if __name__ == "__main__":
    main()
