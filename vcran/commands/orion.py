"""``vcran orion init|delete SCENARIO --orion URL``: the original VC-RAN's "Initialize FOCB" / "Delete FOCB entity"."""

from __future__ import annotations

import argparse

from vcran.commands import CommandError, add_scenario_argument, load_scenario
from vcran.commands._orion import add_connection_arguments, client_from_args, setup_logging

HELP = "create (init: delete, then recreate) or remove (delete) the fleet's robot entities in Orion"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("action", choices=("init", "delete"))
    add_scenario_argument(parser, "; its robots are the entities")
    add_connection_arguments(parser)


def run(args: argparse.Namespace) -> int:
    from transports.orion.client import OrionError
    from vcran.core.opil.build import motion_message
    from vcran.core.opil.codec import encode_entity_json, split_batch
    from vcran.core.opil.messages import AssignmentStatus, PolygonStamped, RanStatus, Time
    from vcran.sim.opil.ran import description

    setup_logging()
    scenario = load_scenario(args.scenario, "vcran orion")
    client = client_from_args(args)
    entity_type = scenario.settings.entity_type
    try:
        removed = sum(client.delete_entity(r.id, entity_type) for r in scenario.robots)
        if args.action == "delete":
            print(f"deleted {removed} of {len(scenario.robots)} entities of type {entity_type}")
            return 0
        entities = []
        for r in scenario.robots:
            footprint = PolygonStamped.from_xy(r.footprint)
            attrs = {
                "current_motion": motion_message(Time(), *r.pose, 0.0, 0.0),
                "assignment_state": AssignmentStatus(footprint=footprint),
                "ran_status": RanStatus(carrying=r.carrying),
                "robot_description": description(r, footprint),
            }
            entities.append(encode_entity_json(r.id, entity_type, attrs))
        for body in split_batch(entities):
            client.update(body)
    except OrionError as exc:
        raise CommandError(f"{args.action}: {exc}") from None
    finally:
        client.close()
    print(f"initialised {len(scenario.robots)} entities of type {entity_type} ({removed} replaced)")
    return 0
