"""A vehicle's factsheet (§6.15), from its configuration: what the master may send it.

The optional order fields vcran uses are listed as ``SUPPORTED`` (or ``REQUIRED``: node positions, which
it drives to); the ones it refuses (trajectory, corridor) are left out, as §6.1.1 asks: "Optional
parameters that are not listed here are assumed to be not supported by the AGV". The action catalogue is
the configuration's; each action's allowed blocking types are written into its description, since the
official schemas cannot carry ``blockingTypes`` (:mod:`vcran.core.vda5050.factsheet`).
"""

from __future__ import annotations

from vcran.core.vda5050.config import VehicleConfig
from vcran.core.vda5050.enums import (
    AgvClass,
    AgvKinematic,
    BlockingType,
    LocalizationType,
    NavigationType,
    Support,
)
from vcran.core.vda5050.errors import WARNINGS
from vcran.core.vda5050.factsheet import (
    AgvAction,
    AgvGeometry,
    Envelope2d,
    Factsheet,
    LoadSpecification,
    MaxArrayLens,
    MaxStringLens,
    OptionalParameter,
    PhysicalParameters,
    PolygonPoint,
    ProtocolFeatures,
    ProtocolLimits,
    Timing,
    TypeSpecification,
)
from vcran.core.vda5050.header import Header

#: Optional order fields the vehicle acts on.
OPTIONAL: tuple[tuple[str, Support], ...] = (
    ("order.nodes.nodePosition", Support.REQUIRED),
    ("order.nodes.nodePosition.theta", Support.SUPPORTED),
    ("order.nodes.nodePosition.allowedDeviationXY", Support.SUPPORTED),
    ("order.edges.maxSpeed", Support.SUPPORTED),
)
#: Conditions that can be reported besides the warnings (errors.py).
CONDITIONS = 3


def factsheet(config: VehicleConfig, header: Header) -> Factsheet:
    p = config.physical
    actions = tuple(
        AgvAction(action_type=a.action_type, action_scopes=tuple(sorted(a.scopes, key=lambda s: s.value)),
                  action_description=_describe(a.description, a.blocking),
                  action_parameters=a.parameters or None)
        for a in config.actions)
    envelopes = (Envelope2d(set="footprint", polygon_points=tuple(PolygonPoint(x=x, y=y) for x, y in p.footprint),
                            description="the vehicle's outline"),) if p.footprint else None
    return Factsheet(
        header=header,
        type_specification=TypeSpecification(
            series_name=config.series_name, series_description="a vcran simulated vehicle",
            agv_kinematic=AgvKinematic.DIFF, agv_class=AgvClass.CARRIER, max_load_mass=p.max_load_mass,
            localization_types=(LocalizationType.NATURAL,), navigation_types=(NavigationType.VIRTUAL_LINE_GUIDED,)),
        physical_parameters=PhysicalParameters(
            speed_min=0.0, speed_max=p.speed_max, acceleration_max=p.acceleration_max,
            deceleration_max=p.deceleration_max, height_max=p.height_max, width=p.width, length=p.length),
        protocol_limits=ProtocolLimits(
            max_string_lens=MaxStringLens(), max_array_lens=MaxArrayLens(state_errors=WARNINGS + CONDITIONS),
            timing=Timing(min_order_interval=0.0, min_state_interval=0.0,
                          default_state_interval=config.state_interval,
                          visualization_interval=config.visualization_interval)),
        protocol_features=ProtocolFeatures(
            optional_parameters=tuple(OptionalParameter(parameter=name, support=s) for name, s in OPTIONAL),
            agv_actions=actions),
        agv_geometry=AgvGeometry(envelopes2d=envelopes),
        load_specification=LoadSpecification(),
    )


def _describe(text: str, blocking: frozenset[BlockingType]) -> str:
    kinds = ", ".join(b.value for b in BlockingType if b in blocking)
    return f"{text} Blocking types: {kinds}." if text else f"Blocking types: {kinds}."
