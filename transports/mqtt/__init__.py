"""VDA 5050 live over MQTT (docs/contract.md §11; docs/vda5050.md, "Live over MQTT"): the vehicles' transport and the
master's client, on paho-mqtt 2.x (the ``vda5050`` extra).

* :mod:`~transports.mqtt.topics`: broker URLs, topic levels, QoS and retained flags (§6.2, §6.3);
* :mod:`~transports.mqtt.client`: one connection with reconnect and back-off, shared by both sides;
* :mod:`~transports.mqtt.connection`: the ``connection`` topic and the last will (§6.14);
* :mod:`~transports.mqtt.transport`: :class:`MqttTransport`, the simulated fleet's side;
* :mod:`~transports.mqtt.master`: :class:`MqttMaster`, a master's side;
* :mod:`~transports.mqtt.manage`: :class:`~transports.mqtt.manage.MqttLoop`, a Python master on it (``vcran manage --mqtt``).
"""

from __future__ import annotations

try:
    import paho.mqtt  # noqa: F401
except ModuleNotFoundError:
    raise ModuleNotFoundError("VDA 5050 over MQTT needs paho-mqtt, which the 'vda5050' extra installs: "
                              "pip install 'vcran[vda5050]'", name="paho") from None

from transports.mqtt.client import MqttOptions, MqttUnavailable
from transports.mqtt.master import MqttMaster
from transports.mqtt.topics import DEFAULT_INTERFACE, BrokerUrl, FleetVehicle, MqttUrlError, VehicleAddress, parse_url
from transports.mqtt.transport import MqttTransport

__all__ = ["DEFAULT_INTERFACE", "BrokerUrl", "FleetVehicle", "MqttMaster", "MqttOptions", "MqttTransport",
           "MqttUnavailable", "MqttUrlError", "VehicleAddress", "parse_url"]
