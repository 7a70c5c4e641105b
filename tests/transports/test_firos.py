"""vcran driven the way OPIL's own planner side drives a RAN (issue 29 item 3; docs/contract.md §2, §7): FIROS at
iml130/firos 8b581f3 with OPIL's NGSI encoder, ``fiwareobjectconverter==0.1.1`` (tests/transports/firos.py
says what FIROS does and where), against ``vcran broker`` and ``vcran live`` as their own processes on
127.0.0.1, as a user starts them.

The planner starts after vcran (its subscriptions are all late: vcran has written its first
``robot_description`` before any of them exists) and renews every subscription twice a second; it writes
a whole task (two motions, a load) and a cancel, encoded by the converter from ROS-message-like objects,
and decodes every notification with the converter into exactly the fields of the attribute's ``.msg``.
"""

from __future__ import annotations

import json
import uuid

import httpx
import pytest

from tests.transports.test_live import broker_process, free_port, live_time, stop, vcran, wait_until  # noqa: F401
from vcran.cli import main

firos = pytest.importorskip("tests.transports.firos")  # needs the test extra's fiwareobjectconverter
from tests.transports.firos import (  # noqa: E402
    HEADER,
    ID,
    MRP,
    PUBLISHED,
    TOPICS,
    Planner,
    Time,
    check_fields,
    check_types,
    decode,
    ros,
)

DESCRIPTION_PERIOD = 5.0  # simulated seconds: half a second of wall time at --factor 10

# One robot with a battery (so battery_state is published too) and a shelf within reach of (2, 0).
SCENARIO = f"""
[simulation]
name = "firos"
seed = 1
duration = 100000.0
task_timeout = 3600.0     # R7: far beyond the test, whatever the machine's load
description_period = {DESCRIPTION_PERIOD}
[simulation.action_durations]
load = 2.0
[[robots]]
id = "robot_1"
pose = [0.0, 0.0, 0.0]
max_velocity = 1.0
capacity = 1
[robots.battery]
capacity = 10.0
per_metre = 0.05
resolution = 0.001
[[stations]]
id = "shelf"
position = [2.0, 1.0]
reach = 1.5
parts = 2
"""


def uuid_of(name: str) -> bytes:
    """The planner's own ids: uuids, with an empty description, as OPIL's planner writes them."""
    return uuid.uuid5(uuid.NAMESPACE_URL, f"https://example.org/planner/{name}").bytes


def opil_id(name: str):  # noqa: ANN201
    return ros(ID, uuid=uuid_of(name), description="")


def motion(task: str, name: str, n: int, of: int, x: float, y: float):  # noqa: ANN201
    vector = "geometry_msgs/Vector3"
    return ros(f"{MRP}/MotionAssignment",
               header=ros(HEADER, seq=n, stamp=Time(1572008882, 381286634), frame_id="map"),
               point_id=opil_id(name), task_id=opil_id(task), motion_id=opil_id(name),
               point=ros("geometry_msgs/Pose2D", x=x, y=y, theta=0.0), is_waypoint=n < of,
               max_velocity=ros("geometry_msgs/Twist", linear=ros(vector, x=1.0), angular=ros(vector, z=1.0)),
               max_acceleration=ros("geometry_msgs/Accel", linear=ros(vector, x=1.0), angular=ros(vector, z=1.0)),
               sequence=ros(f"{MRP}/Sequence", sequence_number=n, length=of))


def load(task: str, name: str, n: int, of: int):  # noqa: ANN201
    # OPIL's RobotAction.category CATEGORY_LOAD = 10 (RobotAction.msg), one empty Tuple as in OPIL's example
    return ros(f"{MRP}/ActionAssignment", action_id=opil_id(name), task_id=opil_id(task),
               sequence=ros(f"{MRP}/Sequence", sequence_number=n, length=of),
               robot_action=ros(f"{MRP}/RobotAction", category=10, attributes=[ros("mars_common_msgs/Tuple")]))


def cancel(task: str):  # noqa: ANN201
    return ros(f"{MRP}/CancelTask", task_id=opil_id(task))  # nil action and motion ids: the whole task (R8)


def uuid_list(name: str) -> list[int]:
    """An Id's ``uuid`` as the converter decodes it: a list of 16 numbers."""
    return list(uuid_of(name))


def ids(values: list[dict]) -> list[list[int]]:
    return [v["uuid"] for v in values]


def seen(planner: Planner, topic: str, predicate) -> list:  # noqa: ANN001
    """The decoded values of ``topic`` so far that satisfy ``predicate``. Notifications of different
    subscriptions (another attribute, or the same one's renewal) travel in parallel, so a test waits for
    what it expects to have been notified, never for it to be the latest."""
    return [value for _, value in planner.got(topic) if predicate(value)]


def test_a_firos_planner_drives_a_task_and_a_cancel_through_vcran_live_and_the_broker(broker_process, tmp_path):  # noqa: F811 (a fixture)
    url = broker_process
    scenario = tmp_path / "firos.toml"
    scenario.write_text(SCENARIO)
    assert main(["orion", "init", str(scenario), "--orion", url]) == 0
    out = tmp_path / "live"
    live = vcran("live", str(scenario), "--orion", url, "--out", str(out), "--factor", "10",
                 "--notify-url", f"http://127.0.0.1:{free_port()}/notify")
    planner = Planner(url, "robot_1", renew=0.5)
    try:
        # vcran runs, has written its description (t = 0) and listens for its commands; only then the planner
        assert wait_until(lambda: live_time(url) >= 1.0, 15)
        assert wait_until(lambda: httpx.get(f"{url}/v2/subscriptions").json() != [], 10)
        planner.start()

        # robot_description: every description_period, so a planner that subscribed late has it
        assert wait_until(lambda: len({sid for sid, _ in planner.got("robot_description")}) >= 2, 15)

        # a whole task: two motions and a load, each written as FIROS writes it
        planner.write("motion_assignment", motion("T1", "T1_m1", 1, 3, 1.0, 0.0))
        planner.write("motion_assignment", motion("T1", "T1_m2", 2, 3, 2.0, 0.0))
        planner.write("action_assignment", load("T1", "T1_a1", 3, 3))
        assert wait_until(lambda: seen(planner, "ran_status", lambda s: uuid_list("T1") in ids(s["completed"])), 20)
        # OPIL's own status says so too; and the part is on board (docs/contract.md §2) from the status that says T1 is done
        assert wait_until(lambda: seen(planner, "assignment_state",
                                       lambda s: s["last_finished_action"]["uuid"] == uuid_list("T1_a1")), 10)
        assert {s["carrying"] for s in seen(planner, "ran_status", lambda s: uuid_list("T1") in ids(s["completed"]))} == {1}

        # a cancel of a task under way, once the planner sees it run: two of its three motions written, so
        # that it cannot end before the cancel does, however slow the machine
        for n, x in ((1, 4.0), (2, 6.0)):
            planner.write("motion_assignment", motion("T2", f"T2_m{n}", n, 3, x, 0.0))
        assert wait_until(lambda: seen(planner, "assignment_state",
                                       lambda s: s["current_task_id"]["uuid"] == uuid_list("T2")), 20)
        planner.write("cancel_order", cancel("T2"))
        assert wait_until(lambda: seen(planner, "ran_status", lambda s: any(
            end["task_id"]["uuid"] == uuid_list("T2") and end["reason"] == "cancelled" for end in s["cancelled"])), 20)
        # and one of a task vcran never heard of: a ran_error, which the planner decodes as well
        planner.write("cancel_order", cancel("T9"))
        assert wait_until(lambda: planner.got("ran_error"), 10)
        assert wait_until(lambda: planner.got("battery_state"), 10)
        assert wait_until(lambda: len({sid for sid, _ in planner.got("robot_description")}) >= 3, 15)
    finally:
        planner.stop()
        # renewed twice a second and stopped: every planner subscription is gone, only vcran's own is left
        left = httpx.get(f"{url}/v2/subscriptions").json()
        _, err = stop(live)
    assert live.returncode == 0, err
    assert planner.errors == []
    assert [s["description"] for s in left] == ["vcran live: fleet commands"]

    # every notification of every attribute vcran publishes: the NGSI types FIROS rebuilds ROS messages
    # from, and the converter's decoding into exactly the fields of the attribute's .msg
    assert {topic for _, topic, _, _ in planner.received} == set(PUBLISHED)
    for _sid, topic, attribute, value in planner.received:
        check_types(attribute, TOPICS[topic], topic)
        check_fields(value, TOPICS[topic], topic)
    # received while subscribed late, and across renewals: several subscriptions delivered each
    created = {sid for _, sid in planner.created}
    for topic in ("robot_description", "assignment_state"):
        through = {sid for sid, _ in planner.got(topic)}
        assert through <= created and len(through) >= 2, (topic, through)

    summary = json.loads((out / "summary.json").read_text())
    robot = summary["robots"]["robot_1"]
    assert robot["completed"] == [str(uuid.UUID(bytes=uuid_of("T1")))]
    assert robot["cancelled"] == [{"task": str(uuid.UUID(bytes=uuid_of("T2"))), "reason": "cancelled"}]
    assert summary["stations"]["shelf"]["parts"] == 1 and robot["carrying"] == 1
    assert main(["replay", str(out), "--out", str(tmp_path / "replay"), "--verify", "--quiet"]) == 0


def test_orion_init_creates_the_attributes_opils_planner_reads(broker_process, tmp_path):  # noqa: F811
    """``vcran orion init`` (the original VC-RAN's "Initialize FOCB") creates ``assignment_state`` (docs/contract.md §2: the
    name OPIL's planner reads, mod_sw_tp/firos_config/robots.json), not ``assignment_status``, with
    ``current_motion``, ``robot_description`` and ``ran_status``; each decodes with the converter."""
    url = broker_process
    scenario = tmp_path / "firos.toml"
    scenario.write_text(SCENARIO)
    assert main(["orion", "init", str(scenario), "--orion", url]) == 0
    entity = httpx.get(f"{url}/v2/entities/robot_1").json()
    assert set(entity) == {"id", "type", "assignment_state", "current_motion", "robot_description", "ran_status"}
    for topic in ("assignment_state", "current_motion", "robot_description", "ran_status"):
        check_types(entity[topic], TOPICS[topic], topic)
        check_fields(decode(entity, topic), TOPICS[topic], topic)
    assert decode(entity, "ran_status")["carrying"] == 0
