"""The rules a scenario's protocol adds (SPEC §11): VDA 5050 vehicles' identities, and a script of VDA 5050
messages (docs/scenarios.md, "VDA 5050 vehicles").

A scenario speaks one protocol (``[simulation] protocol``). In a VDA 5050 scenario every robot names its
manufacturer and serial number (two levels of its topics, §6.3), no two robots share their topics, and the
script sends ``order`` and ``instantActions`` messages: each a typed message that encodes in its vehicle's
version and passes that version's official schema (what the vehicle would check on receiving it), or a
payload text sent as it is. In an OPIL scenario none of that may appear, and in a VDA 5050 one no OPIL
message or task cycle: each would be silently meaningless to the robots that get it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from vcran.core.scenario import VDA5050, RobotConfig, ScriptEntry
from vcran.core.validity.fields import Problem
from vcran.core.validity.fleet import VEHICLE
from vcran.core.vda5050 import codec, validation
from vcran.core.vda5050.enums import Topic, Version
from vcran.core.vda5050.order import InstantActions, Order

#: The topics a script sends on, and the message model of each.
SCRIPT_TOPICS: dict[str, type] = {Topic.ORDER.value: Order, Topic.INSTANT_ACTIONS.value: InstantActions}
_SET_PROTOCOL = f'set [simulation] protocol = "{VDA5050}"'


def vehicle_problems(robots: Sequence[Any], protocol: str) -> list[Problem]:
    """In a VDA 5050 scenario each robot's manufacturer and serial number, and topics of its own; in an
    OPIL one, no VDA 5050 identity at all (said of the first key given)."""
    out = []
    topics: dict[tuple[str, str, str], int] = {}
    for i, r in enumerate(robots):
        if not isinstance(r, RobotConfig):
            continue
        if protocol != VDA5050:
            given = next((key for key in VEHICLE if getattr(r, key) is not None), None)
            if given is not None:
                out.append(Problem(f"robots[{i}].{given}", f"a VDA 5050 vehicle's; this scenario's robots speak "
                                                            f"{protocol} ({_SET_PROTOCOL} for VDA 5050 vehicles)"))
            continue
        missing = [key for key in ("manufacturer", "serial_number") if getattr(r, key) is None]
        if missing:
            out += [Problem(f"robots[{i}].{key}", "missing: a VDA 5050 vehicle names its manufacturer and serial "
                                                  "number (§6.3: levels of its topics)") for key in missing]
            continue
        interface, manufacturer, serial, _ = r.vda5050_identity
        other = topics.setdefault((interface, manufacturer, serial), i)
        if other != i:
            out.append(Problem(f"robots[{i}].serial_number",
                               f"{interface}/v2/{manufacturer}/{serial} are the topics of robots[{other}] too: "
                               "each vehicle needs its own (a serial number unique per manufacturer)"))
    return out


def script_problems(script: Sequence[Any], cycles: Sequence[Any], robots: Sequence[Any], protocol: str,
                    fields_too: bool = True) -> list[Problem]:
    """Every script entry in its scenario's protocol; in a VDA 5050 scenario each message for its vehicle's
    version (``fields_too``: a file's reader built and checked them already)."""
    vehicles = {r.id: r for r in robots if isinstance(r, RobotConfig)}
    out = []
    for k, e in enumerate(script):
        if not isinstance(e, ScriptEntry):
            continue  # the shared rules say so
        where = f"script[{k}]"
        vda = e.attribute in SCRIPT_TOPICS
        if protocol != VDA5050 and vda:
            out.append(Problem(f"{where}.kind", f"{e.attribute} is a VDA 5050 message; this scenario's robots speak "
                                                f"{protocol} ({_SET_PROTOCOL})"))
        elif protocol == VDA5050 and not vda:
            out.append(Problem(f"{where}.kind", f"an OPIL message ({e.attribute}) in a VDA 5050 scenario: its script "
                                                f"sends {' and '.join(SCRIPT_TOPICS)}"))
        elif vda and fields_too and (problem := message_problem(e, vehicles.get(e.robot))):
            out.append(Problem(f"{where}.{problem[0]}", problem[1]))
    if protocol == VDA5050:
        out += [Problem(f"cycles[{k}]", "a task cycle sends OPIL tasks; a VDA 5050 scenario's script sends "
                                        f"{' and '.join(SCRIPT_TOPICS)}") for k in range(len(cycles))]
    return out


def message_problem(e: ScriptEntry, vehicle: RobotConfig | None) -> tuple[str, str] | None:
    """``(key, problem)``: what is wrong with a VDA 5050 script entry's message (or payload) for ``vehicle``: a message of its
    topic's kind that ``vehicle``'s version encodes and its official schema accepts (the vehicle checks as
    much on receiving it), or a payload text, sent as it is."""
    if e.message is None:
        if isinstance(e.raw, str):
            return None
        return ("payload", f"expected the payload as text, got {type(e.raw).__name__}")
    if e.raw is not None:
        return ("payload", "give either message or payload, not both")
    kind = SCRIPT_TOPICS[e.attribute]
    if not isinstance(e.message, kind):
        return ("message", f"expected {'an' if kind is Order else 'a'} {kind.__name__} for topic "
                                 f"{e.attribute}, got {type(e.message).__name__}")
    if vehicle is None:
        return None  # the shared rules name the unknown robot
    version = Version(vehicle.vda5050_identity[3])
    try:
        doc = codec.to_plain(e.message, version)
    except (codec.EncodeError, AttributeError, TypeError) as exc:  # a field holding what no message can
        return ("message", str(exc))
    found = validation.first_problem(validation.inbound(Topic(e.attribute), version), doc)
    if found is not None:
        return ("message", f"{found[0]}: {found[1]} (VDA 5050 {version.value}'s schema)")
    return None

