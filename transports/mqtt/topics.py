"""VDA 5050's MQTT addressing (§6.2, §6.3, §6.14 of the specification): the broker's URL, the topic levels
of each vehicle, and how each topic is delivered (QoS, retained).

Both sides of the edge use it: the vehicles' transport (:mod:`transports.mqtt.transport`) and the master's
client (:mod:`transports.mqtt.master`), so a topic is spelled and read in one place.
"""

from __future__ import annotations

import ipaddress
from collections.abc import Iterable
from dataclasses import dataclass
from datetime import datetime
from urllib.parse import urlsplit

from vcran.core.scenario import Scenario
from vcran.core.vda5050.config import VehicleConfig
from vcran.core.vda5050.enums import Topic, Version
from vcran.core.vda5050.fleet import vehicle_config
from vcran.core.vda5050.header import DEFAULT_EPOCH

#: The port MQTT brokers listen on without TLS (IANA).
DEFAULT_PORT = 1883
#: §6.3's example and the name every VDA 5050 master expects unless told otherwise.
DEFAULT_INTERFACE = "uagv"

_EXPECTED = "expected mqtt://HOST[:PORT]"


class MqttUrlError(ValueError):
    """A broker URL vcran cannot use; the message is one line naming the URL and what is wrong."""


@dataclass(frozen=True, slots=True)
class BrokerUrl:
    host: str
    port: int = DEFAULT_PORT

    def __str__(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"mqtt://{host}:{self.port}"


def parse_url(text: str) -> BrokerUrl:
    """``mqtt://HOST[:PORT]`` (port 1883 by default), or an :class:`MqttUrlError` saying what is wrong.

    ``mqtts://`` is refused: vcran's edge speaks plain MQTT only (a TLS-terminating bridge or a broker
    listener on a trusted network serves it). Credentials in the URL are refused too: a URL ends up in
    shell histories and process lists.
    """
    if not isinstance(text, str) or not text or any(c.isspace() for c in text):
        raise MqttUrlError(f"{text!r}: white space or an empty URL; {_EXPECTED}")
    try:
        parts = urlsplit(text)
        port = parts.port  # raises ValueError for a port out of range or not a number
    except ValueError as exc:
        raise MqttUrlError(f"{text!r}: not a valid URL ({exc}); {_EXPECTED}") from None
    scheme = parts.scheme.lower()
    if scheme == "mqtts":
        raise MqttUrlError(f"{text!r}: TLS (mqtts://) is not supported; use mqtt:// to a listener on a "
                           "trusted network, or a local bridge that speaks TLS to the broker")
    if scheme != "mqtt":
        raise MqttUrlError(f"{text!r}: the scheme must be mqtt://; {_EXPECTED}")
    if parts.username is not None or parts.password is not None:
        raise MqttUrlError(f"{text!r}: credentials in the URL are not supported; {_EXPECTED}")
    if not parts.hostname:
        raise MqttUrlError(f"{text!r}: no host; {_EXPECTED}")
    if parts.path not in ("", "/") or parts.query or parts.fragment:
        raise MqttUrlError(f"{text!r}: a path, query or fragment has no place in a broker URL; {_EXPECTED}")
    if port == 0:
        raise MqttUrlError(f"{text!r}: port 0 is no address a broker listens on; {_EXPECTED}")
    host = parts.hostname
    if parts.netloc.split("@")[-1].startswith("["):
        try:
            ipaddress.IPv6Address(host)
        except ValueError:
            raise MqttUrlError(f"{text!r}: {host!r} is not an IPv6 address; {_EXPECTED}") from None
    return BrokerUrl(host, DEFAULT_PORT if port is None else port)


# --- topics ------------------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Delivery:
    qos: int
    retain: bool


#: §6.2: QoS 0 for every topic but ``connection`` (QoS 1); §6.14 and §6.15: ``connection`` and
#: ``factsheet`` are sent retained.
DELIVERY: dict[Topic, Delivery] = {
    Topic.ORDER: Delivery(0, False),
    Topic.INSTANT_ACTIONS: Delivery(0, False),
    Topic.STATE: Delivery(0, False),
    Topic.VISUALIZATION: Delivery(0, False),
    Topic.CONNECTION: Delivery(1, True),
    Topic.FACTSHEET: Delivery(0, True),
}

#: What a vehicle receives (§6.5); the rest it sends.
TO_VEHICLE = (Topic.ORDER, Topic.INSTANT_ACTIONS)
FROM_VEHICLE = (Topic.STATE, Topic.VISUALIZATION, Topic.CONNECTION, Topic.FACTSHEET)

_TOPICS = {t.value: t for t in Topic}


def level_error(value: object) -> str | None:
    """Why ``value`` cannot be one topic level (§6.3: no ``/``, and no ``$``; MQTT: no wildcard, no NUL)."""
    if not isinstance(value, str) or not value:
        return "must be a non-empty string"
    bad = sorted({c for c in value if c in "/+#$\0"})
    if bad:
        return f"must not contain {' '.join(repr(c) for c in bad)} (a topic level, §6.3)"
    return None


@dataclass(frozen=True, slots=True)
class VehicleAddress:
    """The first four topic levels of one vehicle: ``interfaceName/majorVersion/manufacturer/serialNumber``."""

    interface_name: str
    major: str
    manufacturer: str
    serial_number: str

    def __post_init__(self) -> None:
        for name, value in (("interfaceName", self.interface_name), ("majorVersion", self.major),
                            ("manufacturer", self.manufacturer), ("serialNumber", self.serial_number)):
            problem = level_error(value)
            if problem is not None:
                raise ValueError(f"{name} {value!r}: {problem}")

    def topic(self, topic: Topic) -> str:
        return f"{self}/{topic.value}"

    def __str__(self) -> str:
        return f"{self.interface_name}/{self.major}/{self.manufacturer}/{self.serial_number}"


def fleet_filter(interface_name: str, major: str, topic: Topic) -> str:
    """The subscription that matches ``topic`` of every vehicle of an interface: ``uagv/v2/+/+/state``."""
    return f"{interface_name}/{major}/+/+/{topic.value}"


def parse_topic(text: str) -> tuple[VehicleAddress, Topic] | None:
    """``text`` as a vehicle's address and topic, or None where it is not a VDA 5050 topic."""
    levels = text.split("/")
    if len(levels) != 5 or levels[4] not in _TOPICS:
        return None
    try:
        return VehicleAddress(*levels[:4]), _TOPICS[levels[4]]
    except ValueError:
        return None


@dataclass(frozen=True, slots=True)
class FleetVehicle:
    """One vehicle as the MQTT edge knows it: vcran's robot id (what :class:`~vcran.core.wire.Inbound` and
    :class:`~vcran.core.wire.Publish` name), its topics, the version it encodes, and the calendar its
    header timestamps are on (the vehicle's ``VehicleConfig.epoch``)."""

    robot: str
    address: VehicleAddress
    version: Version = Version.V2_1_0
    epoch: datetime = DEFAULT_EPOCH

    @classmethod
    def of(cls, robot: str, config: VehicleConfig, interface_name: str = DEFAULT_INTERFACE) -> FleetVehicle:
        """The vehicle of ``config`` (manufacturer, serial number, version, epoch) under ``interface_name``."""
        address = VehicleAddress(interface_name, config.version.major, config.manufacturer, config.serial_number)
        return cls(robot, address, config.version, config.epoch)

    def __post_init__(self) -> None:
        if self.address.major != self.version.major:
            raise ValueError(f"{self.robot}: majorVersion {self.address.major!r} does not match version "
                             f"{self.version.value} ({self.version.major})")


def fleet_of(scenario: Scenario) -> list[FleetVehicle]:
    """A VDA 5050 scenario's vehicles as both sides of the broker address them: each robot's identity,
    version and calendar (:func:`~vcran.core.vda5050.fleet.vehicle_config`) under its own ``interface_name``
    (``uagv`` unless it says otherwise, §6.3)."""
    return [FleetVehicle.of(r.id, vehicle_config(r, scenario.settings), r.vda5050_identity[0]) for r in scenario.robots]


def check_fleet(vehicles: Iterable[FleetVehicle]) -> dict[str, FleetVehicle]:
    """The fleet by robot id; a ValueError names robots that repeat an id or share their topics."""
    by_robot: dict[str, FleetVehicle] = {}
    by_address: dict[VehicleAddress, str] = {}
    for vehicle in vehicles:
        if vehicle.robot in by_robot:
            raise ValueError(f"robot {vehicle.robot!r} is listed twice")
        other = by_address.get(vehicle.address)
        if other is not None:
            raise ValueError(f"robots {other!r} and {vehicle.robot!r} share the topics {vehicle.address}/...")
        by_robot[vehicle.robot] = vehicle
        by_address[vehicle.address] = vehicle.robot
    if not by_robot:
        raise ValueError("no vehicle to connect")
    return by_robot
