"""The rules of a scenario's protocol (docs/contract.md §11, docs/scenarios.md "VDA 5050 vehicles"): which settings,
robots' fields and script entries it allows.

A scenario speaks one protocol (``[simulation] protocol``). In a VDA 5050 scenario every robot names its
manufacturer and serial number (two levels of its topics, §6.3), no two robots share their topics, and the
script sends ``order`` and ``instantActions`` messages, or payload texts sent as they are. In an OPIL
scenario none of that may appear, nor the calendar of VDA 5050's headers (``epoch``) or its state's cadence
(``state_interval``), and in a VDA 5050 one no OPIL message or task cycle: each would be silently
meaningless to the robots that get it. Like OPIL's, a VDA 5050 message is checked as it is built (the
file's reader decodes it against its vehicle's version's official schema,
:mod:`vcran.io.scenario_vda5050`), not here: the shared core imports no protocol; a message built in code
is validated by its vehicle when it arrives, as every message a vehicle receives is.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from vcran.core.scenario import POLLING, VDA5050, VDA5050_TOPICS, LinkSettings, RobotConfig, ScriptEntry, Settings
from vcran.core.validity.fields import Problem
from vcran.core.validity.fleet import FINE_POSITIONING, VEHICLE

_SET_PROTOCOL = f'set [simulation] protocol = "{VDA5050}"'


def settings_problems(settings: Settings) -> list[Problem]:
    """``epoch`` is the calendar of VDA 5050's headers (§6.4); OPIL's messages carry no calendar (their stamps
    are simulated seconds), so an OPIL scenario that sets one asks for what nothing would read. Likewise
    ``state_interval``, the longest a VDA 5050 vehicle goes without a state (§6.10): OPIL's robots send
    theirs every ``telemetry_period``."""
    if settings.protocol == VDA5050:
        return []
    out = []
    if settings.epoch is not None:
        out.append(Problem("simulation.epoch", f"the calendar of VDA 5050 headers; this scenario's robots speak "
                                               f"{settings.protocol}, whose messages carry none ({_SET_PROTOCOL})"))
    if settings.state_interval is not None:
        out.append(Problem("simulation.state_interval",
                           f"the longest a VDA 5050 vehicle goes without a state (§6.10); this scenario's "
                           f"robots speak {settings.protocol}, whose telemetry_period says how often they send "
                           f"theirs ({_SET_PROTOCOL})"))
    return out


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


def link_problems(link: Any, protocol: str) -> list[Problem]:
    """Polling is how OPIL's RAN reads what Orion holds (docs/contract.md §9); a VDA 5050 vehicle gets each message as
    it is sent (MQTT, §6.2), so a VDA 5050 scenario that asks for polling asks for what cannot be. Loss is the other way
    round: MQTT's QoS 0 loses messages (§6.2), Orion's HTTP link loses none (docs/loop.md), so an OPIL scenario
    that asks for loss asks for what cannot be."""
    if not isinstance(link, LinkSettings):
        return []
    if protocol == VDA5050 and link.inbound == POLLING:
        return [Problem("link.inbound", f"{POLLING!r} is how OPIL's RAN reads Orion; a VDA 5050 vehicle gets each "
                                        f"message as it is sent (MQTT): leave inbound out")]
    if protocol != VDA5050 and link.loss:
        return [Problem("link.loss", "is VDA 5050's (MQTT's QoS 0 loses messages); Orion's link loses none, what an "
                                     "OPIL manager loses is a polling read's overwrite (inbound = 'polling'): leave loss out")]
    return []


def script_problems(script: Sequence[Any], cycles: Sequence[Any], protocol: str) -> list[Problem]:
    """Every script entry in its scenario's protocol: OPIL messages and task cycles in an OPIL scenario,
    VDA 5050 messages (or payloads) in a VDA 5050 one."""
    out = []
    for k, e in enumerate(script):
        if not isinstance(e, ScriptEntry):
            continue  # the shared rules say so
        where = f"script[{k}]"
        vda = e.attribute in VDA5050_TOPICS
        if protocol != VDA5050 and vda:
            out.append(Problem(f"{where}.kind", f"{e.attribute} is a VDA 5050 message; this scenario's robots speak "
                                                f"{protocol} ({_SET_PROTOCOL})"))
        elif protocol == VDA5050 and not vda:
            out.append(Problem(f"{where}.kind", f"an OPIL message ({e.attribute}) in a VDA 5050 scenario: its script "
                                                f"sends {' and '.join(VDA5050_TOPICS)}"))
        elif vda and (problem := _message_or_payload(e)):
            out.append(Problem(f"{where}.{problem[0]}", problem[1]))
    if protocol == VDA5050:
        out += [Problem(f"cycles[{k}]", "a task cycle sends OPIL tasks; a VDA 5050 scenario's script sends "
                                        f"{' and '.join(VDA5050_TOPICS)}") for k in range(len(cycles))]
    return out


def _message_or_payload(e: ScriptEntry) -> tuple[str, str] | None:
    """``(key, problem)``: a VDA 5050 entry sends a message or a payload text, not both, not neither."""
    if e.message is not None:
        return ("payload", "give either message or payload, not both") if e.raw is not None else None
    if isinstance(e.raw, str):
        return None
    return "payload", f"expected the payload as text, got {type(e.raw).__name__}"


def duration_problems(durations: Any, protocol: str) -> list[Problem]:
    """``fine_positioning`` is how long a VDA 5050 vehicle's finePositioning takes: an OPIL robot has none."""
    if protocol != VDA5050 and isinstance(durations, dict) and FINE_POSITIONING in durations:
        return [Problem(f"simulation.action_durations.{FINE_POSITIONING}", "a VDA 5050 vehicle's finePositioning; this "
                        f"scenario's robots speak {protocol} ({_SET_PROTOCOL})")]
    return []


def trigger_problems(script: Sequence[Any], faults: Sequence[Any], protocol: str, endless: bool) -> list[Problem]:
    """``trigger`` faults press a VDA 5050 vehicle's trigger (waitForTrigger, §6.8.1): an OPIL robot has none.
    A run that ends only when idle (``endless``: no duration) never ends while an order's waitForTrigger waits:
    a robot whose script orders one needs a later trigger fault or cancelOrder (like a pause without a resume)."""
    if protocol != VDA5050:
        return [Problem(f"faults[{k}].kind", f"a trigger presses a VDA 5050 vehicle's button (waitForTrigger); this "
                                              f"scenario's robots speak {protocol} ({_SET_PROTOCOL})")
                for k, f in enumerate(faults) if getattr(f, "kind", None) == "trigger"]
    if not endless:
        return []
    waits: dict[str, float] = {}
    for e in script:
        message = getattr(e, "message", None)
        nodes = getattr(message, "nodes", ())
        if any(a.action_type == "waitForTrigger" for n in nodes for a in n.actions):
            waits.setdefault(e.robot, e.t)
    for e in script:
        actions = getattr(getattr(e, "message", None), "actions", ())
        if e.robot in waits and e.t >= waits[e.robot] and any(a.action_type == "cancelOrder" for a in actions):
            del waits[e.robot]
    for f in faults:
        if getattr(f, "kind", None) == "trigger" and f.robot in waits and f.t >= waits[f.robot]:
            del waits[f.robot]
    return [Problem("", f"[[script]]: {robot}'s order at t = {t:g} has a waitForTrigger that no later trigger fault or "
                        "cancelOrder ends, and [simulation] has no duration: with until_idle the run would never end; "
                        "add a [[faults]] kind = \"trigger\", a cancelOrder or a duration") for robot, t in waits.items()]
