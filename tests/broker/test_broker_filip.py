"""vcran's broker driven by FiLiP, the FIWARE Python client (docs/contract.md §7: the broker answers like Orion on
every call FiLiP makes). FiLiP checks the broker's version when it connects, asks for
``options=normalized`` on every read and validates what it gets back with pydantic models, so each call
here fails if the broker answers anything an Orion 4.7 would not."""

from __future__ import annotations

import json
from collections.abc import Iterator

import pytest
from broker_support import Listener
from filip.clients.ngsi_v2 import ContextBrokerClient
from filip.models.base import FiwareHeader
from filip.models.ngsi_v2.base import AttrsFormat
from filip.models.ngsi_v2.context import ContextEntity, NamedContextAttribute
from filip.models.ngsi_v2.subscriptions import Subscription

from tests.conftest import DATA
from vcran.broker import BrokerHandle, start_broker


@pytest.fixture
def broker() -> Iterator[BrokerHandle]:
    with start_broker() as handle:
        yield handle


@pytest.fixture
def cb(broker: BrokerHandle) -> Iterator[ContextBrokerClient]:
    client = ContextBrokerClient(url=broker.url, fiware_header=FiwareHeader(service="plant", service_path="/line1"))
    yield client
    client.close()


def test_filip_connects_and_reads_the_version(cb: ContextBrokerClient) -> None:
    assert cb.get_version()["orion"]["version"] == "4.7.0"


def test_filip_writes_and_reads_entities(cb: ContextBrokerClient) -> None:
    cb.post_entity(ContextEntity(id="robot_1", type="ROBOT", battery={"type": "Number", "value": 1.5707963267948966}))
    entity = cb.get_entity("robot_1")  # options=normalized
    assert entity.get_attribute("battery").value == 1.570796327  # printed as Orion prints doubles
    assert cb.get_entity("robot_1", response_format=AttrsFormat.KEY_VALUES).battery == 1.570796327
    assert cb.get_attribute_value("robot_1", "battery") == 1.570796327
    cb.update_attribute_value(entity_id="robot_1", attr_name="battery", value=80.0)
    cb.update_or_append_entity_attributes("robot_1", [NamedContextAttribute(name="mode", value="auto")], "ROBOT")
    assert [e.id for e in cb.get_entity_list(entity_types=["ROBOT"])] == ["robot_1"]
    assert cb.get_entity_attributes("robot_1", response_format=AttrsFormat.KEY_VALUES) == {"battery": 80, "mode": "auto"}
    cb.delete_entity("robot_1", entity_type="ROBOT")
    assert not cb.does_entity_exist("robot_1", "ROBOT")


def test_filip_reads_an_opil_entity(cb: ContextBrokerClient) -> None:
    """The entity vcran reads and writes (FIROS encoding, type names with dots, nested metadata)."""
    raw = json.loads((DATA / "opil_robot_entity.json").read_text())
    cb.post_entity(ContextEntity(**raw))
    entity = cb.get_entity(raw["id"])
    assert entity.get_attribute_names() == set(raw) - {"id", "type"}
    assert entity.current_motion.type == raw["current_motion"]["type"]
    assert entity.current_motion.value == raw["current_motion"]["value"]


def test_filip_batch_update_query_and_subscriptions(cb: ContextBrokerClient) -> None:
    from filip.models.base import DataType
    from filip.models.ngsi_v2.base import EntityPattern
    from filip.models.ngsi_v2.context import ActionType, Query

    robots = [ContextEntity(id=f"robot_{i}", type="ROBOT", n={"type": DataType.NUMBER, "value": i}) for i in (1, 2)]
    cb.update(entities=robots, action_type=ActionType.APPEND)
    found = cb.query(query=Query(entities=[EntityPattern(idPattern="robot_.*")]))
    assert [e.id for e in found] == ["robot_1", "robot_2"]
    listener = Listener()
    try:
        subscription = Subscription(
            description="vcran test", subject={"entities": [{"id": "robot_1", "type": "ROBOT"}]},
            notification={"http": {"url": listener.url}, "attrs": ["n"]},
        )
        sid = cb.post_subscription(subscription)
        assert cb.get_subscription(sid).description == "vcran test"
        assert [s.id for s in cb.get_subscription_list()] == [sid]
        cb.delete_subscription(sid)
        assert cb.get_subscription_list() == []
    finally:
        listener.stop()


@pytest.mark.slow
def test_filip_reads_the_fleet_while_vcran_live_runs_through_the_broker(broker: BrokerHandle, tmp_path) -> None:
    """Issue 12: a live run against the broker, FiLiP reading the robot's entity meanwhile, as a fleet
    manager written with FiLiP would; what it reads decodes with vcran's codec and moves on."""
    import signal
    import time

    from tests.transports.test_live import DEMO, vcran, wait_until
    from vcran.core.opil.codec import decode_attribute

    live = vcran("live", str(DEMO), "--orion", broker.url, "--out", str(tmp_path / "live"), "--factor", "20", "--quiet")
    client = ContextBrokerClient(url=broker.url)
    try:
        published = {"current_motion", "assignment_state", "ran_status", "robot_description"}
        # the first batches create the entity; under load the one with robot_description may follow later
        assert wait_until(lambda: client.does_entity_exist("robot_1", "ROBOT") and published
                          <= client.get_entity("robot_1", entity_type="ROBOT").get_attribute_names(), 20)
        stamps = []
        for _ in range(3):
            entity = client.get_entity("robot_1", entity_type="ROBOT")  # options=normalized, pydantic-checked
            assert published <= entity.get_attribute_names()
            raw = entity.current_motion.model_dump()  # FiLiP keeps non-NGSI type names as plain attributes
            motion = decode_attribute("current_motion", raw)
            stamps.append(motion.current_position.header.stamp.to_seconds())
            time.sleep(0.3)
        assert stamps == sorted(stamps) and stamps[-1] > stamps[0]  # the live run publishes while FiLiP reads
    finally:
        client.close()
        live.send_signal(signal.SIGINT)
        _, stderr = live.communicate(timeout=30)
    assert live.returncode == 0, stderr
