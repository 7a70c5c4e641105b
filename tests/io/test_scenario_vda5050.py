"""A scenario's protocol (issue 31 item 3, docs/contract.md §11; docs/scenarios.md "VDA 5050 vehicles"): ``[simulation]
protocol``, a VDA 5050 vehicle's identity on ``[[robots]]``, and a script of ``order`` and ``instantActions``
messages stamped by vcran and checked against the vehicle's version's official schema as the file loads.

Expected values come from the files and the text: headers as §6.4 and docs/scenarios.md say vcran stamps
them (headerId from 0 per robot and topic in time order; the entry's time on the scenario's calendar, 1970
unless ``[simulation] epoch`` says otherwise), problems
in the wording docs/scenarios.md gives, located by the file's own keys.
"""

from __future__ import annotations

import json
import tomllib
from dataclasses import replace
from typing import Any

import jsonschema
import pytest

import vcran
from tests.conftest import ROOT
from vcran.core.scenario import ScriptEntry
from vcran.core.validity import validate
from vcran.core.vda5050.enums import BlockingType, Version
from vcran.core.vda5050.fleet import MasterFleet
from vcran.core.vda5050.order import InstantActions, Order
from vcran.io.scenario_file import ScenarioError, parse
from vcran.io.scenario_schema import scenario_schema
from vcran.io.scenario_toml import dumps, loop_dict, scenario_dict

FLEET = """
[simulation]
duration = 100.0
protocol = "vda5050"
[[robots]]
id = "r1"
manufacturer = "acme"
serial_number = "0001"
"""

#: An order to drive from (0, 0) to (2, 0), without its header.
ORDER = """
message.orderId = "o1"
message.orderUpdateId = 0
message.nodes = [
  { nodeId = "a", sequenceId = 0, released = true, nodePosition = { x = 0.0, y = 0.0, mapId = "map" }, actions = [] },
  { nodeId = "b", sequenceId = 2, released = true, nodePosition = { x = 2.0, y = 0.0, mapId = "map" }, actions = [] },
]
message.edges = [
  { edgeId = "a-b", sequenceId = 1, released = true, startNodeId = "a", endNodeId = "b", actions = [] },
]
"""
PAUSE = '{"actions": [{"actionType": "startPause", "actionId": "pause_1", "blockingType": "HARD"}]}'


def entry(t: float, kind: str, body: str, robot: str = "r1") -> str:
    return f'\n[[script]]\nt = {t}\nrobot = "{robot}"\nkind = "{kind}"\n{body}\n'


def load(text: str) -> vcran.Scenario:
    return parse(tomllib.loads(text), "x.toml")


def refused(text: str) -> str:
    with pytest.raises(ScenarioError) as caught:
        load(text)
    return str(caught.value)


# --- loading -------------------------------------------------------------------------------------------


def test_a_vda5050_scenario_loads_its_vehicles_and_stamps_its_messages() -> None:
    s = load(FLEET + entry(1.0, "order", ORDER) + entry(2.5, "instantActions", f"message = '{PAUSE}'"))
    assert s.settings.protocol == "vda5050"
    r = s.robots[0]
    assert (r.manufacturer, r.serial_number, r.interface_name, r.version) == ("acme", "0001", None, None)
    assert r.vda5050_identity == ("uagv", "acme", "0001", "2.1.0")  # the defaults: §6.3's uagv, 2.1.0
    order, pause = s.script
    assert (order.t, order.robot, order.attribute, order.raw) == (1.0, "r1", "order", None)
    assert isinstance(order.message, Order)
    h = order.message.header  # §6.4, stamped as a master would: the first order of r1, at 1 s
    assert (h.header_id, h.timestamp, h.version, h.manufacturer, h.serial_number) == (
        0, "1970-01-01T00:00:01.00Z", "2.1.0", "acme", "0001")
    assert [n.node_id for n in order.message.nodes] == ["a", "b"]
    assert [(e.edge_id, e.start_node_id, e.end_node_id) for e in order.message.edges] == [("a-b", "a", "b")]
    assert isinstance(pause.message, InstantActions) and pause.attribute == "instantActions"
    assert pause.message.header.header_id == 0  # its own topic counts from 0 too
    assert pause.message.header.timestamp == "1970-01-01T00:00:02.50Z"
    [action] = pause.message.actions
    assert (action.action_type, action.action_id, action.blocking_type) == ("startPause", "pause_1", BlockingType.HARD)


def test_a_scenario_sets_its_calendar_and_its_script_is_stamped_on_it() -> None:
    """``[simulation] epoch`` (docs/scenarios.md): simulated second 0 is that instant, so a message sent at t
    is stamped epoch + t (§6.4: ISO 8601, UTC), cut to the hundredth as every vcran stamp. By hand:
    23:59:58.5 on 1 March 2026 plus 1 s is 23:59:59.50; plus 2.5 s is 00:00:01.00 on 2 March; plus 0.004 s is
    23:59:58.504, cut to 23:59:58.50."""
    fleet = FLEET.replace('protocol = "vda5050"\n', 'protocol = "vda5050"\nepoch = "2026-03-01T23:59:58.5Z"\n')
    s = load(fleet + entry(1.0, "order", ORDER) + entry(2.5, "instantActions", f"message = '{PAUSE}'")
             + entry(0.004, "instantActions", f"message = '{PAUSE}'"))
    assert s.settings.epoch == "2026-03-01T23:59:58.5Z"  # as written: the trace header records it so
    assert [(e.t, e.message.header.timestamp) for e in s.script] == [
        (0.004, "2026-03-01T23:59:58.50Z"), (1.0, "2026-03-01T23:59:59.50Z"), (2.5, "2026-03-02T00:00:01.00Z")]
    assert load(FLEET).settings.epoch is None  # unset: the protocol's default calendar, 1970 (above)


def test_header_ids_count_per_robot_and_topic_in_the_order_sent_not_the_files() -> None:
    """§6.4: headerId is "incremented by 1 with each sent message": the script sends by time (equal times in
    file order, as every script entry), whatever order the file lists them in."""
    second = FLEET + 'pose = [0.0, 0.0, 0.0]\n[[robots]]\nid = "r2"\nmanufacturer = "acme"\nserial_number = "0002"\n'
    o2 = ORDER.replace('"o1"', '"o2"')
    s = load(second + entry(5.0, "order", o2) + entry(1.0, "order", ORDER) + entry(1.0, "order", ORDER, "r2")
             + entry(5.0, "order", o2, "r2") + entry(3.0, "order", ORDER.replace('"o1"', '"o3"')))
    stamped = [(e.t, e.robot, e.message.order_id, e.message.header.header_id, e.message.header.serial_number)
               for e in s.script]
    assert stamped == [(1.0, "r1", "o1", 0, "0001"), (1.0, "r2", "o1", 0, "0002"), (3.0, "r1", "o3", 1, "0001"),
                       (5.0, "r1", "o2", 2, "0001"), (5.0, "r2", "o2", 1, "0002")]


def test_a_message_as_a_json_text_is_the_same_message() -> None:
    table = load(FLEET + entry(1.0, "order", ORDER)).script[0]
    body = tomllib.loads(ORDER)["message"]
    text = load(FLEET + entry(1.0, "order", f"message = '{json.dumps(body)}'")).script[0]
    assert text == table


def test_a_payload_is_kept_as_the_text_sent() -> None:
    s = load(FLEET + entry(1.0, "order", "payload = '{\"orderId\": 5}'")
             + entry(2.0, "instantActions", 'payload = { actions = "none" }'))
    assert [(e.attribute, e.message, e.raw) for e in s.script] == [
        ("order", None, '{"orderId": 5}'), ("instantActions", None, '{"actions": "none"}')]


def test_a_2_0_0_vehicle_stamps_its_version_and_is_checked_with_its_schema() -> None:
    """docs/vda5050.md "Versions": an action parameter's value may be an object only from 2.1.0 on."""
    param = ('message = { actions = [{ actionType = "startPause", actionId = "p", blockingType = "NONE", '
             'actionParameters = [{ key = "k", value = { a = 1 } }] }] }')
    s = load(FLEET + entry(1.0, "instantActions", param))
    assert s.script[0].message.header.version == "2.1.0"
    old = FLEET.replace('serial_number = "0001"', 'serial_number = "0001"\nversion = "2.0.0"')
    assert load(old + entry(1.0, "order", ORDER)).script[0].message.header.version == "2.0.0"
    assert refused(old + entry(1.0, "instantActions", param)).startswith(
        "x.toml: script[0]: field 'message': $.actions[0].actionParameters[0].value: ")


def test_the_bundled_vda5050_scenarios_load() -> None:
    """The demo as three orders (the robots, stations and their times of scenarios/demo.toml), and the
    warehouse's fleet, stations and jobs with the reference master."""
    demo, vda = vcran.load_scenario("demo"), vcran.load_scenario("vda5050")
    assert vda.settings.protocol == "vda5050" and demo.settings.protocol == "opil"
    assert vda.stations == demo.stations
    assert [replace(r, manufacturer=None, serial_number=None, version=None) for r in vda.robots] == list(demo.robots)
    orders = [e.message for e in vda.script]
    assert [(e.t, o.order_id, o.header.header_id) for e, o in zip(vda.script, orders)] == [
        (1.0, "100", 0), (20.0, "200", 1), (45.0, "300", 2)]
    ends = [(o.nodes[-1].node_position.x, o.nodes[-1].node_position.y) for o in orders]
    assert ends == [(4.0, 2.0), (-4.0, 2.0), (0.0, 0.0)]  # conveyor_1's dock, conveyor_2's, home
    actions = [[(a.action_type, a.parameter("stationName")) for a in o.nodes[-1].actions] for o in orders]
    assert actions == [[("pick", "conveyor_1")], [("drop", "conveyor_2")], []]

    warehouse, vw = vcran.load_scenario("warehouse"), vcran.load_scenario("vda5050-warehouse")
    assert (vw.stations, vw.job_stream, vw.link) == (warehouse.stations, warehouse.job_stream, warehouse.link)
    assert [r.pose for r in vw.robots] == [r.pose for r in warehouse.robots]
    assert vw.manager.path == "vcran.managers.vda5050:MasterControl"
    fleet = MasterFleet.of(vw)  # the vehicles as a master knows them: by the scenario's serial numbers
    assert fleet.serials == tuple(f"{i:04d}" for i in range(1, 11))
    assert {(a.config.manufacturer, a.config.version) for a in fleet.vehicles} == {("vcran", Version.V2_1_0)}


# --- problems: the file's keys, one line each ------------------------------------------------------------


@pytest.mark.parametrize(("text", "told"), [
    (FLEET.replace('"vda5050"', '"mqtt"'),
     "x.toml: simulation: field 'protocol': unknown protocol 'mqtt'; known: opil, vda5050"),
    (FLEET + 'version = "2.2.0"\n',
     "x.toml: robots[0]: field 'version': unknown VDA 5050 version '2.2.0'; known: 2.1.0, 2.0.0"),
    (FLEET.replace('"acme"', '"acme/labs"'),
     "x.toml: robots[0]: field 'manufacturer': contains /, which an MQTT topic level cannot hold (VDA 5050 §6.3: "
     "it names the vehicle's topics)"),
    (FLEET + 'interface_name = "uagv/#"\n',
     "x.toml: robots[0]: field 'interface_name': contains / #, which an MQTT topic level cannot hold (VDA 5050 "
     "§6.3: it names the vehicle's topics)"),
    (FLEET + 'interface_name = ""\n', "x.toml: robots[0]: field 'interface_name': expected a non-empty string, got ''"),
    (FLEET.replace('serial_number = "0001"\n', ""),
     "x.toml: robots[0]: field 'serial_number': missing: a VDA 5050 vehicle names its manufacturer and serial "
     "number (§6.3: levels of its topics)"),
    (FLEET + '[[robots]]\nid = "r2"\nmanufacturer = "acme"\nserial_number = "0001"\n',
     "x.toml: robots[1]: field 'serial_number': uagv/v2/acme/0001 are the topics of robots[0] too: each vehicle "
     "needs its own (a serial number unique per manufacturer)"),
    (FLEET.replace('protocol = "vda5050"\n', ""),
     "x.toml: robots[0]: field 'manufacturer': a VDA 5050 vehicle's; this scenario's robots speak opil (set "
     "[simulation] protocol = \"vda5050\" for VDA 5050 vehicles)"),
    (FLEET + "[link]\ninbound = \"polling\"\n",
     "x.toml: link: field 'inbound': 'polling' is how OPIL's RAN reads Orion; a VDA 5050 vehicle gets each message "
     "as it is sent (MQTT): leave inbound out"),
    (FLEET + entry(1.0, "motion", 'task = "1"\nid = "m"\nseq = [1, 1]\npoint = [1.0, 0.0, 0.0]'),
     "x.toml: script[0]: field 'kind': an OPIL message (motion_assignment) in a VDA 5050 scenario: its script "
     "sends order and instantActions"),
    (FLEET + entry(1.0, "order", ORDER) + entry(2.0, "cycle", 'every = 10.0\ntasks = [{ actions = ["dummy"] }]'),
     "x.toml: script[1]: a task cycle sends OPIL tasks; a VDA 5050 scenario's script sends order and "
     "instantActions"),
    ('[simulation]\nduration = 100.0\n[[robots]]\nid = "r1"\n' + entry(1.0, "order", ORDER),
     "x.toml: script[0]: field 'kind': order is a VDA 5050 message; this scenario's robots speak opil (set "
     "[simulation] protocol = \"vda5050\")"),
    (FLEET + entry(1.0, "order", ORDER, robot="r9"),
     "x.toml: script[0]: field 'robot': no robot 'r9' in this scenario (R11); robots: r1"),
    (FLEET + entry(200.0, "order", ORDER),
     "x.toml: script[0]: field 't': the entry is sent at t = 200, after the run ends (duration = 100)"),
    (FLEET + entry(1.0, "order", ""),
     "x.toml: script[0]: field 'message': give either message (checked, stamped by vcran) or payload (a text "
     "sent as it is)"),
    (FLEET + entry(1.0, "order", ORDER + "payload = '{}'"),
     "x.toml: script[0]: field 'message': give either message (checked, stamped by vcran) or payload (a text "
     "sent as it is)"),
    (FLEET + entry(1.0, "order", "payload = 5"), "x.toml: script[0]: field 'payload': expected a table or a JSON "
                                                 "text, got int"),
    (FLEET + entry(1.0, "order", "message = '{\"orderId\": '"),
     "x.toml: script[0]: field 'message': not valid JSON: Expecting value: line 1 column 13 (char 12)"),
    (FLEET + entry(1.0, "order", "message = '[1, 2]'"),
     "x.toml: script[0]: field 'message': expected the order message as a table or a JSON object, got list"),
    (FLEET + entry(1.0, "order", ORDER + "message.headerId = 7"),
     "x.toml: script[0]: field 'message': headerId is the header's, which vcran stamps (§6.4: headerId per robot "
     "and topic in the order sent); leave it out, or send the message as it is with payload"),
    (FLEET + entry(1.0, "order", ORDER + "message.zoneSetId = 1979-05-27"),
     "x.toml: script[0]: field 'message': not a JSON value: Object of type date is not JSON serializable"),
    (FLEET.replace("duration", 'epoch = "2026-01-01T01:00:00+01:00"\nduration'),
     "x.toml: simulation: field 'epoch': '2026-01-01T01:00:00+01:00' is not a UTC date and time as ISO 8601 "
     "writes it: \"2026-01-01T00:00:00Z\" (seconds, optionally with up to six decimals, then Z for UTC)"),
    (FLEET.replace("duration", 'epoch = "2026-01-01"\nduration'),
     "x.toml: simulation: field 'epoch': '2026-01-01' is not a UTC date and time as ISO 8601 writes it: "
     "\"2026-01-01T00:00:00Z\" (seconds, optionally with up to six decimals, then Z for UTC)"),
    (FLEET.replace("duration", 'epoch = "2026-02-29T00:00:00Z"\nduration'),  # 2026 is no leap year
     "x.toml: simulation: field 'epoch': '2026-02-29T00:00:00Z': day is out of range for month"),
    (FLEET.replace("duration", 'epoch = "1969-12-31T23:59:59Z"\nduration'),
     "x.toml: simulation: field 'epoch': '1969-12-31T23:59:59Z': the years of the calendar are 1970 to 2999"),
    (FLEET.replace("duration", 'epoch = ""\nduration'),
     "x.toml: simulation: field 'epoch': expected a non-empty string, got ''"),
    (FLEET.replace("duration", "epoch = 2026-01-01T01:00:00+01:00\nduration"),  # TOML's own date-time
     "x.toml: simulation: field 'epoch': a TOML date-time; write it in UTC as a string, in quotes: "
     "epoch = \"2026-01-01T00:00:00Z\""),
    ('[simulation]\nduration = 100.0\nepoch = "2026-01-01T00:00:00Z"\n[[robots]]\nid = "r1"\n',
     "x.toml: simulation: field 'epoch': the calendar of VDA 5050 headers; this scenario's robots speak opil, "
     "whose messages carry none (set [simulation] protocol = \"vda5050\")"),
    (FLEET + entry(1.0, "order", ORDER.replace('nodeId = "b", sequenceId = 2, released = true, ',
                                               'nodeId = "b", sequenceId = 2, ')),
     "x.toml: script[0]: field 'message': $.nodes[1].released: required field missing (VDA 5050 2.1.0's schema)"),
    (FLEET + entry(1.0, "instantActions", 'message = { actions = [{ actionType = "startPause", actionId = "p", '
                                          'blockingType = "SOMETIMES" }] }'),
     "x.toml: script[0]: field 'message': $.actions[0].blockingType: \"SOMETIMES\" is not one of NONE, SOFT, HARD "
     "(VDA 5050 2.1.0's schema)"),
])
def test_every_problem_names_the_entry_and_the_field(text: str, told: str) -> None:
    assert refused(text) == told


def test_the_model_is_checked_without_a_file() -> None:
    """The rules are the model's (vcran.core.validity): a scenario changed in code is told in the file's words."""
    s = load(FLEET + entry(1.0, "order", ORDER))
    r = s.robots[0]
    assert validate(s) == []
    assert str(validate(replace(s, robots=(replace(r, manufacturer=None),)))[0]) == (
        "robots[0]: field 'manufacturer': missing: a VDA 5050 vehicle names its manufacturer and serial number "
        "(§6.3: levels of its topics)")
    assert str(validate(replace(s, settings=replace(s.settings, protocol="opil")))[0]).startswith(
        "robots[0]: field 'manufacturer': a VDA 5050 vehicle's; this scenario's robots speak opil")
    both = replace(s.script[0], raw="{}")
    assert str(validate(replace(s, script=(both,)))[0]) == (
        "script[0]: field 'payload': give either message or payload, not both")
    settings = s.settings
    assert str(validate(replace(s, settings=replace(settings, epoch="2026-01-01 00:00:00Z")))[0]) == (
        "simulation: field 'epoch': '2026-01-01 00:00:00Z' is not a UTC date and time as ISO 8601 writes it: "
        "\"2026-01-01T00:00:00Z\" (seconds, optionally with up to six decimals, then Z for UTC)")
    assert str(validate(replace(s, settings=replace(settings, protocol="opil", epoch="2026-01-01T00:00:00Z")))[0]) \
        == ("simulation: field 'epoch': the calendar of VDA 5050 headers; this scenario's robots speak opil, whose "
            "messages carry none (set [simulation] protocol = \"vda5050\")")
    neither = ScriptEntry(1.0, "r1", "order")
    assert str(validate(replace(s, script=(neither,)))[0]) == (
        "script[0]: field 'payload': expected the payload as text, got NoneType")


# --- the schema and the writer ----------------------------------------------------------------------------


def test_the_schema_knows_the_protocol_the_vehicle_and_the_messages() -> None:
    schema = scenario_schema()
    assert schema["properties"]["simulation"]["properties"]["protocol"] == {"enum": ["opil", "vda5050"],
                                                                           "default": "opil"}
    robot = schema["properties"]["robots"]["items"]["properties"]
    assert robot["version"] == {"enum": ["2.1.0", "2.0.0"]}
    assert robot["serial_number"]["type"] == "string" and "serial_number" not in schema["properties"]["robots"][
        "items"].get("required", [])  # required in a VDA 5050 scenario only: a rule between sections, the model's
    entries = schema["properties"]["script"]["items"]
    order = next(b["then"] for b in entries["allOf"] if b["if"]["properties"]["kind"]["const"] == "order")
    assert order["properties"]["message"] == order["properties"]["payload"] == {"type": ["object", "string"]}
    for name in ("vda5050", "vda5050-warehouse"):
        jsonschema.validate(tomllib.loads((ROOT / "scenarios" / f"{name}.toml").read_text()), schema)
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(tomllib.loads(FLEET.replace('"vda5050"', '"mqtt"')), schema)


def test_the_writer_writes_a_vda5050_scenario_back() -> None:
    s = load(FLEET + 'version = "2.0.0"\ninterface_name = "fleet"\n' + entry(1.0, "order", ORDER)
             + entry(2.0, "instantActions", f"message = '{PAUSE}'") + entry(3.0, "order", "payload = 'not json'"))
    again = parse(tomllib.loads(dumps(scenario_dict(s, s.script))), "x.toml")
    assert again == s


def test_the_writer_writes_the_calendar_back_and_checks_headers_on_it() -> None:
    """A scenario with an epoch written back loads as the same scenario: its script's headers stamped on that
    calendar, which the writer checks they are."""
    fleet = FLEET.replace("duration", 'epoch = "2026-01-01T00:00:00.125Z"\nduration')
    s = load(fleet + entry(1.0, "order", ORDER))
    assert s.script[0].message.header.timestamp == "2026-01-01T00:00:01.12Z"  # 1.125 s, cut to hundredths
    assert parse(tomllib.loads(dumps(scenario_dict(s, s.script))), "x.toml") == s
    on_1970 = load(FLEET + entry(1.0, "order", ORDER)).script
    with pytest.raises(ValueError, match="vcran stamps .*'2026-01-01T00:00:01.12Z'.*, the message has .*'1970-01-01T00:00:01.00Z'"):
        scenario_dict(s, on_1970)


def test_the_writer_writes_a_vda5050_closed_loop_back() -> None:
    """vcran fuzz --manager saves a shrunk failing scenario with loop_dict: the protocol and the vehicles too."""
    s = vcran.load_scenario("vda5050-warehouse")
    assert parse(tomllib.loads(dumps(loop_dict(s))), s.source, "vda5050-warehouse") == s


def test_the_writer_refuses_a_header_the_reader_would_not_stamp() -> None:
    s = load(FLEET + entry(1.0, "order", ORDER))
    message: Any = s.script[0].message
    moved = replace(s.script[0], message=replace(message, header=replace(message.header, header_id=4)))
    with pytest.raises(ValueError, match="a scenario file cannot express this header: vcran stamps"):
        scenario_dict(s, [moved])


def test_the_trace_header_carries_the_protocol_and_identity_only_when_set() -> None:
    """Scenario.fleet_dict is a run's trace header: an OPIL scenario's stays as it was."""
    vda = load(FLEET).fleet_dict()
    assert vda["simulation"]["protocol"] == "vda5050"
    assert {k: vda["robots"][0][k] for k in ("manufacturer", "serial_number")} == {"manufacturer": "acme",
                                                                                  "serial_number": "0001"}
    assert "epoch" not in vda["simulation"]  # unset: left out, as every key added since
    dated = load(FLEET.replace("duration", 'epoch = "2026-01-01T00:00:00Z"\nduration')).fleet_dict()
    assert dated["simulation"]["epoch"] == "2026-01-01T00:00:00Z"  # as written, which a replay reads back
    opil = vcran.load_scenario("demo").fleet_dict()
    assert "protocol" not in opil["simulation"] and "manufacturer" not in opil["robots"][0]
