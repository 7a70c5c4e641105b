"""``vcran decode FILE``: an NGSI entity (normalized or keyValues) as plain decoded messages (SPEC §8).

Prints one JSON object keyed by attribute, each the message's plain form (ids as canonical uuid strings
with their descriptions). Attributes that are not RAN messages are listed on stderr as skipped, so that a
whole entity read from Orion can be inspected. Bad input exits 1 with the codec's message on stderr.
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
    from vcran.core.codec import decode_entity, unknown_attributes
    from vcran.core.plain import to_plain

    try:
        entity = _load(args.file)
        messages = decode_entity(entity)
    except OSError as exc:
        return _fail(args.file, exc.strerror or str(exc))
    except ValueError as exc:  # bad JSON, or a CodecError naming the field path
        return _fail(args.file, str(exc))
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


def _fail(file: str, message: str) -> int:
    print(f"vcran decode: {'stdin' if file == '-' else file}: {message}", file=sys.stderr)
    return 1
