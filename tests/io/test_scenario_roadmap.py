"""docs/contract.md §12 ``[roadmap]`` in scenario files: read into the model, its problems told as one line naming the
file, the entry and the field (the rules are :func:`vcran.core.traffic.roadmap.validate`'s, the reader only
locates them), written back by the scenario writer, carried by the trace header only when present."""

from __future__ import annotations

import json
import re
import tomllib

import jsonschema
import pytest

from vcran.core.traffic.roadmap import Edge, Node, Roadmap
from vcran.io.scenario_file import ScenarioError, parse
from vcran.io.scenario_schema import scenario_schema
from vcran.io.scenario_toml import dumps

FLEET = """
[simulation]
duration = 60.0
[[robots]]
id = "robot_1"
"""

ROADMAP = """
[roadmap]
nodes = [
  { id = "W", x = 0, y = 0 },
  { id = "M", x = 10, y = 0 },
  { id = "E", x = 20, y = 0 },
  { id = "P", x = 10, y = 2, waiting = true },
]
edges = [
  { from = "W", to = "M" },
  { from = "M", to = "E", speed = 0.5 },
  { from = "M", to = "P", one_way = true },
]
[[stations]]
id = "west"
position = [-1.0, 0.0]
dock = "W"
[[stations]]
id = "east"
position = [20.0, 0.0]
"""


def load(text: str):
    return parse(tomllib.loads(text), "<test>")


def test_the_compact_form_loads_into_the_model() -> None:
    s = load(FLEET + ROADMAP)
    assert s.roadmap == Roadmap(
        (Node("W", 0.0, 0.0), Node("M", 10.0, 0.0), Node("E", 20.0, 0.0), Node("P", 10.0, 2.0, waiting=True)),
        (Edge("W", "M"), Edge("M", "E", speed=0.5), Edge("M", "P", one_way=True)),
    )
    # a named dock is the node's position, any heading; a station without a dock sits on a node (E)
    assert [(st.dock, st.dock_node) for st in s.stations] == [((0.0, 0.0, None), "W"), (None, None)]


def test_tables_of_tables_load_the_same() -> None:
    text = FLEET + """
[[roadmap.nodes]]
id = "a"
x = 0
y = 0
[[roadmap.nodes]]
id = "b"
x = 5
y = 0
[[roadmap.edges]]
from = "a"
to = "b"
"""
    assert load(text).roadmap == Roadmap((Node("a", 0.0, 0.0), Node("b", 5.0, 0.0)), (Edge("a", "b"),))


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ('{ from = "W", to = "M" }', '{ from = "W", to = "Q" }',
         "<test>: roadmap.edges[0]: field 'to': unknown node 'Q'; nodes: W, M, E, P"),
        ('{ id = "E", x = 20, y = 0 }', '{ id = "E", x = 10, y = 0 }',
         "<test>: roadmap.edges[1]: zero length: 'M' and 'E' are both at [10, 0]"),
        ('{ id = "P", x = 10, y = 2, waiting = true }', '{ id = "M", x = 10, y = 2 }',
         "<test>: roadmap.nodes[3]: field 'id': duplicate id 'M' (nodes[1])"),
        ('speed = 0.5', 'speed = -1', "<test>: roadmap.edges[1]: field 'speed': must be a positive number of m/s"),
        ('dock = "W"', 'dock = "Z"', "<test>: stations[0]: field 'dock': unknown node 'Z'; nodes: W, M, E, P"),
        ('position = [20.0, 0.0]', 'position = [21.0, 0.0]',
         "<test>: stations[1]: field 'position': [21, 0] is off the roadmap"),
        ('waiting = true', 'wait = true', "<test>: roadmap.nodes[3]: field 'wait': unknown key (a typo?)"),
        ('{ id = "W", x = 0, y = 0 }', '{ id = "W", x = "0", y = 0 }',
         "<test>: roadmap.nodes[0]: field 'x': expected a finite number, got '0'"),
        ('dock = "W"', 'dock = ""', "<test>: stations[0]: field 'dock': expected [x, y] or [x, y, theta], or a "
                                    "roadmap node's id, got ''"),
    ],
    ids=["unknown-node", "zero-length", "duplicate-id", "speed", "unknown-dock", "dock-off-map", "typo", "type",
         "empty-dock"],
)
def test_each_problem_is_one_line_naming_the_entry(old: str, new: str, message: str) -> None:
    """Issue 32 item 1: unknown nodes, duplicate ids, zero-length edges, a dock off the map: one line."""
    assert old in ROADMAP
    with pytest.raises(ScenarioError, match=re.escape(message)) as caught:
        load(FLEET + ROADMAP.replace(old, new, 1))
    assert "\n" not in str(caught.value)


def test_a_named_dock_needs_a_roadmap() -> None:
    text = FLEET + '[[stations]]\nid = "s"\nposition = [0.0, 0.0]\ndock = "W"\n'
    with pytest.raises(ScenarioError, match=re.escape("<test>: stations[0]: field 'dock': names the roadmap node "
                                                      "'W', but the scenario has no [roadmap]")):
        load(text)


def test_an_empty_roadmap_is_refused() -> None:
    with pytest.raises(ScenarioError, match=re.escape("<test>: roadmap: field 'nodes': a roadmap needs at least "
                                                      "one node")):
        load(FLEET + "[roadmap]\n")


def test_a_named_dock_beyond_the_station_reach_is_refused() -> None:
    # station west at (-1, 0), reach 1 m by default: node M is 11 m away
    with pytest.raises(ScenarioError, match=r"stations\[0\]: field 'dock': \[10, 0\] is 11 m from"):
        load(FLEET + ROADMAP.replace('dock = "W"', 'dock = "M"'))


def test_the_trace_header_and_the_writer_carry_the_roadmap_back() -> None:
    s = load(FLEET + ROADMAP)
    header = json.loads(json.dumps(s.fleet_dict()))
    assert header["roadmap"]["edges"][2] == {"from": "M", "to": "P", "one_way": True}
    assert header["stations"][0]["dock"] == "W"
    for data in (header, tomllib.loads(dumps(header))):
        again = parse(data, "<again>")
        assert again.roadmap == s.roadmap and again.stations == s.stations


def test_a_scenario_without_a_roadmap_keeps_its_header() -> None:
    """Existing outputs stay byte-identical: no roadmap, no key (and a station's dock as before)."""
    s = load(FLEET + '[[stations]]\nid = "s"\nposition = [0.0, 0.0]\ndock = [0.5, 0.0]\n')
    header = s.fleet_dict()
    assert "roadmap" not in header and header["stations"][0]["dock"] == [0.5, 0.0]


def test_the_schema_knows_the_roadmap() -> None:
    schema = scenario_schema()
    data = tomllib.loads(FLEET + ROADMAP)
    jsonschema.validate(data, schema)
    node = schema["properties"]["roadmap"]["properties"]["nodes"]["items"]
    assert node["required"] == ["id", "x", "y"] and node["additionalProperties"] is False
    data["roadmap"]["edges"][0]["one_way"] = "yes"
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(data, schema)
