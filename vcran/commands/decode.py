"""``vcran decode FILE``: an NGSI entity (normalized or keyValues) as plain decoded messages (docs/contract.md §8).

Prints one JSON object keyed by attribute, each the message's plain form (ids as canonical uuid strings
with their descriptions). Attributes that are not RAN messages are listed on stderr as skipped, so that a
whole entity read from Orion can be inspected. Bad input is a CommandError (exit 2) with the codec's
message, which names the field path.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

HELP = "print the decoded messages of an NGSI entity (JSON file, or - for stdin) as plain JSON"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", metavar="FILE", help="NGSI v2 entity as JSON (normalized or keyValues); - reads stdin")


def run(args: argparse.Namespace) -> int:
    from vcran.commands import CommandError
    from vcran.core.opil.codec import decode_entity, unknown_attributes
    from vcran.core.opil.plain import to_plain

    name = "stdin" if args.file == "-" else args.file
    try:
        entity = _load(args.file)
        messages = decode_entity(entity)
    except OSError as exc:
        raise CommandError(f"{name}: {exc.strerror or exc}") from None
    except ValueError as exc:  # bad JSON, or a CodecError naming the field path
        raise CommandError(f"{name}: {exc}") from None
    skipped = unknown_attributes(entity)
    if skipped:
        print(f"vcran decode: skipped attributes that are not RAN messages: {', '.join(skipped)}", file=sys.stderr)
    json.dump({name: to_plain(message) for name, message in messages.items()}, sys.stdout, indent=2, ensure_ascii=False)
    sys.stdout.write("\n")
    return 0


def _load(file: str) -> Any:
    data = sys.stdin.buffer.read() if file == "-" else Path(file).read_bytes()
    try:
        return json.loads(data)
    except RecursionError:
        raise ValueError("bad JSON: nested too deeply") from None
    except ValueError as exc:  # JSONDecodeError, UnicodeDecodeError, over-long integers
        raise ValueError(f"bad JSON: {exc}") from None

