"""Hypothesis strategies for every VDA 5050 message kind, in either version (docs/contract.md §11, docs/vda5050.md).

:func:`messages` draws any model of a topic as its version allows it (2.1.0-only fields only in 2.1.0,
the value ranges of the official schemas): what the codec must encode into schema-valid JSON and decode
back unchanged. The models are drawn from their own annotations (:func:`vcran.core.vda5050.codec.wire_form`),
with the ranges below where a schema narrows a type, so a field added to a model is fuzzed at once.

These messages are well-formed, not meaningful: an order's graph is random. Orders a vehicle can drive
come from :mod:`vcran.testing.vda5050.plans`.
"""

from __future__ import annotations

import math
from functools import cache
from typing import Any

from vcran.testing._extra import require_hypothesis

require_hypothesis(__name__)

from hypothesis import strategies as st

from vcran.core.vda5050 import factsheet as fs
from vcran.core.vda5050 import order as om
from vcran.core.vda5050 import state as sm
from vcran.core.vda5050.codec import MODELS, wire_form
from vcran.core.vda5050.enums import ActionStatus, Topic, Version
from vcran.core.vda5050.header import Header, timestamp

UINT32 = 2**32 - 1
#: Text the wire can carry: JSON strings are Unicode without lone surrogates (orjson refuses those).
TEXT = st.text(st.characters(exclude_categories=["Cs"]), max_size=6)
FINITE = st.floats(-1e9, 1e9, allow_nan=False)
ANGLE = st.floats(-math.pi, math.pi)
SHARE = st.floats(0.0, 1.0)
NONNEGATIVE = st.floats(0.0, 1e9)
#: The statuses the official state schemas allow: both leave PAUSED out of the enum (docs/vda5050.md).
STATUSES = [s for s in ActionStatus if s is not ActionStatus.PAUSED]


def json_values(objects: bool = True) -> st.SearchStrategy[Any]:
    """Any JSON value but null (which no schema allows where VDA 5050 takes any value); with
    ``objects=False`` the value itself is not an object (2.0.0's action parameters), though arrays may
    hold objects."""
    scalars = st.booleans() | st.integers(-UINT32, UINT32) | FINITE | TEXT
    nested = st.recursive(scalars | st.none(), lambda inner: st.lists(inner, max_size=2)
                          | st.dictionaries(TEXT, inner, max_size=2), max_leaves=4)
    top = scalars | st.lists(nested, max_size=2)
    return top | st.dictionaries(TEXT, nested, max_size=2) if objects else top


def headers(version: Version) -> st.SearchStrategy[Header]:
    return st.builds(
        Header, header_id=st.integers(0, UINT32), timestamp=st.floats(0, 4e9).map(timestamp),
        version=st.just(version.value), manufacturer=TEXT, serial_number=TEXT,
    )


@cache
def _overrides(version: Version) -> dict[tuple[type, str], st.SearchStrategy[Any]]:
    """Where a schema narrows a field's type (ranges, enums with a gap, fields it types wrongly)."""
    old = version is Version.V2_0_0
    return {
        (om.NodePosition, "theta"): ANGLE | st.none(),
        (om.NodePosition, "allowed_deviation_xy"): NONNEGATIVE | st.none(),
        (om.NodePosition, "allowed_deviation_theta"): st.floats(0.0, math.pi) | st.none(),
        (om.Edge, "orientation"): ANGLE | st.none(),
        (om.Trajectory, "degree"): st.integers(1, 5),
        (om.Trajectory, "knot_vector"): st.lists(SHARE, max_size=4).map(tuple),
        (om.ControlPoint, "weight"): NONNEGATIVE | st.none(),
        (om.Corridor, "left_width"): NONNEGATIVE,
        (om.Corridor, "right_width"): NONNEGATIVE,
        (om.ActionParameter, "value"): json_values(objects=not old),
        (sm.NodeState, "node_position"): st.none() | st.builds(
            om.NodePosition, x=FINITE, y=FINITE, theta=ANGLE if old else ANGLE | st.none(), map_id=TEXT),
        (sm.EdgeState, "trajectory"): st.none() | st.builds(
            om.Trajectory, degree=st.integers(1, 5), knot_vector=st.lists(SHARE, max_size=4).map(tuple),
            control_points=st.lists(st.builds(om.ControlPoint, x=FINITE, y=FINITE,
                                              weight=NONNEGATIVE if old else NONNEGATIVE | st.none()),
                                    max_size=2).map(tuple)),
        (sm.AgvPosition, "localization_score"): SHARE | st.none(),
        (sm.BatteryState, "battery_health"): st.integers(0, 100) | st.none(),
        (sm.BatteryState, "reach"): st.integers(0, UINT32) | st.none(),
        (sm.Load, "weight"): NONNEGATIVE | st.none(),
        (sm.ActionState, "action_status"): st.sampled_from(STATUSES),
        (fs.TypeSpecification, "max_load_mass"): NONNEGATIVE,
        (fs.AgvAction, "blocking_types"): st.none(),
        (fs.Envelope3d, "description"): st.none(),
        (fs.Envelope3d, "data"): st.none() | st.dictionaries(TEXT, json_values(), max_size=2),
    }


@cache
def models(cls: type, version: Version) -> st.SearchStrategy[Any]:
    """Any ``cls`` model ``version`` can carry (see the module docstring); built once per class."""
    overrides = _overrides(version)
    kwargs: dict[str, st.SearchStrategy[Any]] = {}
    for f in wire_form(cls, version):
        if f.absent:
            continue
        if (cls, f.attr) in overrides:
            kwargs[f.attr] = overrides[(cls, f.attr)]
        elif f.flatten:
            kwargs[f.attr] = headers(version)
        else:
            value = _of_kind(f.kind, f.cls, version)
            kwargs[f.attr] = value | st.none() if f.optional else value
    return st.builds(cls, **kwargs)


def _of_kind(kind: str, cls: Any, version: Version) -> st.SearchStrategy[Any]:
    if kind.startswith("tuple:"):
        return st.lists(_of_kind(kind[6:], cls, version), max_size=2).map(tuple)
    simple: dict[str, st.SearchStrategy[Any]] = {
        "str": TEXT, "int": st.integers(0, UINT32), "float": FINITE, "bool": st.booleans(), "any": json_values(),
    }
    if kind in simple:
        return simple[kind]
    if kind == "enum":
        return st.sampled_from(list(cls))
    return st.deferred(lambda: models(cls, version))


def messages(topic: Topic, version: Version) -> st.SearchStrategy[Any]:
    """Any message of ``topic`` in ``version``."""
    return models(MODELS[topic], version)


def orders(version: Version) -> st.SearchStrategy[om.Order]:
    return messages(Topic.ORDER, version)


def instant_actions(version: Version) -> st.SearchStrategy[om.InstantActions]:
    return messages(Topic.INSTANT_ACTIONS, version)


def states(version: Version) -> st.SearchStrategy[sm.State]:
    return messages(Topic.STATE, version)


def visualizations(version: Version) -> st.SearchStrategy[sm.Visualization]:
    return messages(Topic.VISUALIZATION, version)


def connections(version: Version) -> st.SearchStrategy[sm.Connection]:
    return messages(Topic.CONNECTION, version)


def factsheets(version: Version) -> st.SearchStrategy[fs.Factsheet]:
    return messages(Topic.FACTSHEET, version)


__all__ = [
    "messages", "orders", "instant_actions", "states", "visualizations", "connections", "factsheets",
    "headers", "json_values", "models",
]
