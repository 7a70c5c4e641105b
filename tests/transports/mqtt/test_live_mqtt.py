"""``vcran live SCENARIO --mqtt URL`` end to end (docs/contract.md §11; issue 31 item 4, "Must show"): the bundled
vda5050 scenario's vehicle, served by vcran as its own process on a real Mosquitto, driven by a VDA 5050
master written here in plain paho (not vcran's code), its run folder replayed with ``--verify``.

What is expected comes from the VDA 5050 2.1.0 text and from scenarios/vda5050.toml (the vehicle: robot_1,
manufacturer "vcran", serial number "0001", version 2.1.0, standing at (0, 0) facing +x; nothing stands
between (0, 0) and (1, 0): the stations are at (±4, 3)).
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from datetime import datetime
from pathlib import Path
from typing import Any

import pytest
from jsonschema import Draft202012Validator

from tests.transports.mqtt.support import Watcher, retained, vehicle_scenario, wait_until
from vcran.io.trace import read_header, records, trace_in

pytestmark = pytest.mark.slow

VEHICLE = "uagv/v2/vcran/0001"  # §6.3: interfaceName/majorVersion/manufacturer/serialNumber
SCHEMAS = Path(__file__).parents[3] / "vcran/core/vda5050/schemas/2.1.0"
FACTOR = 4.0


def schema(topic: str) -> Draft202012Validator:
    return Draft202012Validator(json.loads((SCHEMAS / f"{topic}.schema").read_text()))


def replay_verify(folder: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "vcran", "replay", str(folder), "--verify"],
                          capture_output=True, text=True, timeout=120)


class Master:
    """A VDA 5050 2.1.0 master in a few lines of paho: headerIds counted per topic (§6.4), all it gets kept."""

    def __init__(self, url: str) -> None:
        self.watcher = Watcher(url, (f"{VEHICLE}/state", f"{VEHICLE}/visualization", f"{VEHICLE}/connection"))
        self.header_ids = {"order": 0, "instantActions": 0}
        self.sent: list[bytes] = []

    def states(self) -> list[dict[str, Any]]:
        return [seen.doc for seen in self.watcher.of("state")]

    def send(self, topic: str, body: dict[str, Any]) -> None:
        header = {"headerId": self.header_ids[topic], "timestamp": "2026-11-27T18:00:00.00Z", "version": "2.1.0",
                  "manufacturer": "vcran", "serialNumber": "0001"}
        self.header_ids[topic] += 1
        payload = json.dumps(header | body, indent=1).encode()  # a master's own spelling: kept byte for byte
        self.sent.append(payload)
        self.watcher.publish(f"{VEHICLE}/{topic}", payload)


def test_a_paho_master_drives_vcran_live_mqtt_and_the_run_replays(broker, live_fleet):
    started = time.time()
    live = live_fleet(broker.url, "vda5050", VEHICLE, factor=FACTOR)
    master = Master(broker.url)
    try:
        # §6.14: the broker holds the vehicle's connection, ONLINE (live_fleet waited for it), retained.
        assert wait_until(lambda: master.watcher.of("connection"))
        online = master.watcher.of("connection")[0]
        assert (online.doc["connectionState"], online.retain, online.qos) == ("ONLINE", True, 1)
        # §6.8.1 stateRequest: "Requests the AGV to send a new state report"; it says where the vehicle stands.
        master.send("instantActions", {"actions": [{"actionId": "ask", "actionType": "stateRequest",
                                                    "blockingType": "NONE"}]})
        assert wait_until(master.states)
        where = master.states()[-1]["agvPosition"]
        assert (where["x"], where["y"], where["positionInitialized"]) == (0.0, 0.0, True)  # the scenario's pose

        # §6.6.2: an order whose first node is where the vehicle stands; the goal 1 m further along +x.
        x, y = where["x"], where["y"]
        master.send("order", {"orderId": "o1", "orderUpdateId": 0, "nodes": [
            {"nodeId": "here", "sequenceId": 0, "released": True, "actions": [],
             "nodePosition": {"x": x, "y": y, "mapId": "map"}},
            {"nodeId": "goal", "sequenceId": 2, "released": True, "actions": [],
             "nodePosition": {"x": x + 1.0, "y": y, "mapId": "map"}},
        ], "edges": [{"edgeId": "here-goal", "sequenceId": 1, "released": True, "startNodeId": "here",
                      "endNodeId": "goal", "actions": []}]})

        def finished() -> dict[str, Any] | None:
            # Figure 8: the order is done when nodeStates and edgeStates are empty, the vehicle stands on its last node
            return next((s for s in master.states() if s["orderId"] == "o1" and not s["nodeStates"]
                         and not s["edgeStates"] and not s["driving"] and s["lastNodeId"] == "goal"), None)

        assert wait_until(finished, timeout=60), master.states()
        done = finished()
        assert done is not None and done["lastNodeSequenceId"] == 2 and not done["errors"]
        assert done["agvPosition"]["x"] == pytest.approx(x + 1.0, abs=0.01)  # §6.10.6: where it stands now
        code, out, err = live.stop()
        assert code == 0, err
        assert wait_until(lambda: master.watcher.of("connection")[-1].doc["connectionState"] == "OFFLINE")
    finally:
        master.watcher.close()

    # Every state, visualization (every telemetry period: the vehicle drove at least 2 s simulated) and
    # connection message the master saw is valid against the official 2.1.0 schemas, and counts its headerId
    # on its own topic (§6.4) without gaps.
    seen = master.watcher.of()
    assert {m.kind for m in seen} == {"state", "visualization", "connection"}
    for message in seen:
        problems = [e.message for e in schema(message.kind).iter_errors(message.doc)]
        assert not problems, (problems, message.doc)
    for kind in ("state", "visualization", "connection"):
        ids = [m.doc["headerId"] for m in seen if m.kind == kind]
        assert ids == list(range(ids[0], ids[0] + len(ids))), (kind, ids)
    # §6.4: "timestamp ... ISO8601, UTC" of when the message was sent. The run's calendar is the wall clock at its
    # start (docs/vda5050.md, "Timestamps"), recorded in the trace header's scenario: between the test's start and
    # the retained ONLINE, which is stamped at simulated 0, the epoch itself (cut to the hundredth). A state
    # stamped at simulated t went out at the wall's epoch + t / FACTOR or later (the clock starts once the fleet
    # is connected and built) and arrived within a few seconds of that: real time, scaled by --factor.
    epoch_text = read_header(trace_in(live.out))["fleet"]["simulation"]["epoch"]
    epoch = datetime.fromisoformat(epoch_text).timestamp()
    assert started - 0.001 <= epoch <= online.received, (started, epoch_text, online.received)
    assert online.doc["timestamp"] == epoch_text[:22] + "Z"  # YYYY-MM-DDTHH:MM:SS.ff of ...SS.fffZ
    for state in master.watcher.of("state"):
        simulated = datetime.fromisoformat(state.doc["timestamp"]).timestamp() - epoch  # cut: up to 0.01 s short
        assert -0.01 < simulated and state.received - 3.0 <= epoch + simulated / FACTOR <= state.received + 0.5, (
            epoch_text, state.doc["timestamp"], state.received)
    # What a newcomer gets: the retained OFFLINE (a graceful end, not the last will's CONNECTIONBROKEN).
    assert retained(broker.url, (f"{VEHICLE}/connection",))[f"{VEHICLE}/connection"].doc["connectionState"] == "OFFLINE"

    # The command's own account: what it started with, and its end-of-run figures.
    assert out.startswith(f"live: 1 VDA 5050 vehicle(s) on {broker.url} ({VEHICLE}), x4; Ctrl-C stops\n"), out
    assert "1 order(s) completed, 0 error(s)" in out and "arrival to the state it caused" in out, out

    # The run folder: its header says how it ran; each message the master sent is recorded as it arrived, byte
    # for byte; and the replay reproduces every record.
    trace = trace_in(live.out)
    assert read_header(trace)["options"] == {"transport": "live-mqtt", "factor": FACTOR, "broker": broker.url}
    inbound = [r for _, r in records(trace, ("in",)) if r.get("dir") == "in"]
    assert [(r["robot"], r["attr"], r["raw"].encode()) for r in inbound] == [
        ("robot_1", "instantActions", master.sent[0]), ("robot_1", "order", master.sent[1])]
    verified = replay_verify(live.out)
    assert verified.returncode == 0, verified.stdout + verified.stderr
    assert "verify: every outbound record, leg (telemetry) and event matches the recording" in verified.stdout


def test_the_broker_gone_mid_run_the_run_goes_on_reconnects_and_replays(broker, live_fleet, tmp_path):
    """docs/contract.md §11, "reconnect with back-off, the simulation goes on": Mosquitto stops while the vehicle
    drives an order and starts again on the same port (without persistence: it forgot everything). The
    vehicle connects again (ONLINE with headerId 2: 0 was the first ONLINE, 1 the last will that went down
    with the broker, docs/vda5050.md "The connection topic"), the order is finished, SIGTERM ends the run
    normally, and its folder replays with --verify: the outage is nowhere in the trace."""
    vehicle = "uagv/v2/vcran/outage-1"
    live = live_fleet(broker.url, vehicle_scenario(tmp_path, "outage-1"), vehicle, factor=2.0)
    master = Watcher(broker.url, (f"{vehicle}/#",))
    try:
        header = {"headerId": 0, "timestamp": "2026-11-27T18:00:00.00Z", "version": "2.1.0", "manufacturer": "vcran",
                  "serialNumber": "outage-1"}
        order = header | {"orderId": "o1", "orderUpdateId": 0, "nodes": [
                     {"nodeId": "a", "sequenceId": 0, "released": True, "actions": [],
                      "nodePosition": {"x": 0.0, "y": 0.0, "mapId": "map"}},
                     {"nodeId": "b", "sequenceId": 2, "released": True, "actions": [],
                      "nodePosition": {"x": 4.0, "y": 0.0, "mapId": "map"}}],
                 "edges": [{"edgeId": "a-b", "sequenceId": 1, "released": True, "startNodeId": "a",
                            "endNodeId": "b", "actions": []}]}
        master.publish(f"{vehicle}/order", json.dumps(order).encode())
        assert wait_until(lambda: any(s.doc["orderId"] == "o1" and s.doc["driving"] for s in master.of("state")))

        broker.stop()
        assert wait_until(lambda: not master.subscribed.is_set())
        broker.start()

        def reconnected() -> bool:
            return any(s.doc["connectionState"] == "ONLINE" and s.doc["headerId"] == 2 for s in master.of("connection"))

        def finished() -> bool:
            return any(s.doc["lastNodeId"] == "b" and not s.doc["nodeStates"] and not s.doc["driving"]
                       for s in master.of("state"))

        assert wait_until(reconnected, timeout=30), [s.doc for s in master.of("connection")]
        # The held state went out right after ONLINE, maybe before this watcher was back: ask for one (§6.8.1).
        assert master.subscribed.wait(10)
        master.publish(f"{vehicle}/instantActions", json.dumps(header | {"actions": [
            {"actionId": "ask", "actionType": "stateRequest", "blockingType": "NONE"}]}).encode())
        assert wait_until(finished, timeout=30), [s.doc for s in master.of("state")]
        assert not any(s.doc["errors"] for s in master.of("state"))  # the stateRequest was valid
        code, out, err = live.stop()
        assert code == 0, err
    finally:
        master.close()
    assert "1 order(s) completed, 0 error(s)" in out and " 1 reconnects;" in out, out  # the end-of-run figures
    verified = replay_verify(live.out)
    assert verified.returncode == 0, verified.stdout + verified.stderr


def test_a_killed_live_mqtt_run_keeps_its_recording_up_to_its_last_tick(broker, live_fleet, tmp_path):
    """docs/outputs.md, "A run killed outright": a VDA 5050 run sends no telemetry frame, so ``vcran live --mqtt``
    hands its files to the operating system at each telemetry tick itself. Killed with SIGKILL after the
    vehicle finished an order, its ``<out>.incomplete`` holds that order (its arrival and the vehicle's
    states) and replays as an incomplete recording that verifies as far as it goes."""
    vehicle = "uagv/v2/vcran/kill-1"
    live = live_fleet(broker.url, vehicle_scenario(tmp_path, "kill-1"), vehicle, factor=4.0)
    master = Watcher(broker.url, (f"{vehicle}/state",))
    try:
        header = {"timestamp": "2026-11-27T18:00:00.00Z", "version": "2.1.0", "manufacturer": "vcran",
                  "serialNumber": "kill-1"}
        master.publish(f"{vehicle}/order", json.dumps(header | {"headerId": 0, "orderId": "o1", "orderUpdateId": 0, "nodes": [
            {"nodeId": "a", "sequenceId": 0, "released": True, "actions": [],
             "nodePosition": {"x": 0.0, "y": 0.0, "mapId": "map"}},
            {"nodeId": "b", "sequenceId": 2, "released": True, "actions": [],
             "nodePosition": {"x": 1.0, "y": 0.0, "mapId": "map"}}],
            "edges": [{"edgeId": "a-b", "sequenceId": 1, "released": True, "startNodeId": "a", "endNodeId": "b",
                       "actions": []}]}).encode())
        assert wait_until(lambda: any(s.doc["lastNodeId"] == "b" and not s.doc["driving"] for s in master.of("state")))
        growing = live.out.with_name(live.out.name + ".incomplete")

        def recorded() -> bool:  # the order's end, flushed at a tick since (no wall-clock wait)
            try:
                return any(r.get("attr") == "state" and r["raw"]["lastNodeId"] == "b" and not r["raw"]["driving"]
                           for _, r in records(growing / "trace.jsonl.zst", ("out",)) if "raw" in r)
            except Exception:  # noqa: BLE001 - a file being written: its last block may be cut off
                return False

        assert wait_until(recorded)
        live.process.kill()
        assert live.stop()[0] == -9
    finally:
        master.close()
    assert not live.out.exists()
    verified = replay_verify(growing)
    assert verified.returncode == 0, verified.stdout + verified.stderr
    assert "(as far as it goes)" in verified.stdout and "incomplete recording" in verified.stderr
