"""Task, motion, action and robot ids (`mars_common_msgs/Id`).

On the wire an id is sixteen bytes plus a free-text description; two ids are the same id when their
bytes are equal, whatever their descriptions say (docs/contract.md §2). Scenario files name ids with plain strings, so
this module also owns the one mapping from a name to bytes. That mapping is part of vcran's public
contract: a recorded trace or a fleet manager's database may hold the uuids, so it must never change.

The mapping (documented in docs/ids.md):

* a name that is already a canonical uuid string (``8-4-4-4-12`` hex digits, any case) maps to exactly
  those bytes and keeps the name as its description;
* any other name maps to ``uuid5(VCRAN_NAMESPACE, name)`` with the name as its description, where
  ``VCRAN_NAMESPACE = uuid5(NAMESPACE_URL, "https://github.com/vcran/vcran/ids")``.
"""

from __future__ import annotations

import hashlib
import re
import uuid as _uuid
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

VCRAN_NAMESPACE = _uuid.uuid5(_uuid.NAMESPACE_URL, "https://github.com/vcran/vcran/ids")

#: The description OPIL's task planner puts on ids it does not use (see the reference cancel_order).
NOT_SUPPORTED = "not supported"

_CANONICAL = re.compile(r"^[0-9a-fA-F]{8}-[0-9a-fA-F]{4}-[0-9a-fA-F]{4}-[0-9a-fA-F]{4}-[0-9a-fA-F]{12}$")


class IdError(ValueError):
    """An id that cannot exist on the wire: wrong length, a byte outside 0..255, a bad string."""


@dataclass(frozen=True, slots=True, eq=False)
class Id:
    """A `mars_common_msgs/Id`: equal and hashed by its uuid bytes only."""

    uuid: bytes
    description: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.uuid, bytes):
            raise IdError(f"uuid must be bytes, got {type(self.uuid).__name__}")
        if len(self.uuid) != 16:
            raise IdError(f"uuid must have 16 bytes, got {len(self.uuid)}")
        if not isinstance(self.description, str):
            raise IdError(f"description must be a string, got {type(self.description).__name__}")

    def __eq__(self, other: object) -> bool:
        if isinstance(other, Id):
            return self.uuid == other.uuid
        return NotImplemented

    def __hash__(self) -> int:
        return hash(self.uuid)

    def __repr__(self) -> str:
        if self.description:
            return f"Id({self.canonical!r}, {self.description!r})"
        return f"Id({self.canonical!r})"

    @property
    def canonical(self) -> str:
        """The canonical lower-case uuid string, e.g. ``05030602-0907-0300-0608-010107040503``."""
        return canonical_uuid(self.uuid)

    @property
    def label(self) -> str:
        """How events and summaries name the id: its description, else its canonical uuid (docs/contract.md §8)."""
        return self.description or self.canonical

    @property
    def is_nil(self) -> bool:
        return self.uuid == bytes(16)

    @property
    def is_unused(self) -> bool:
        """Nil, or marked "not supported" as OPIL's planner does for a whole-task cancel (R8)."""
        return self.is_nil or self.description == NOT_SUPPORTED

    @classmethod
    def from_octets(cls, octets: list[int] | tuple[int, ...], description: str = "") -> Id:
        """Build from the wire's ``uint8[16]`` list, checking every element."""
        if len(octets) != 16:
            raise IdError(f"uuid must have 16 elements, got {len(octets)}")
        for i, b in enumerate(octets):
            if isinstance(b, bool) or not isinstance(b, int) or not 0 <= b <= 255:
                raise IdError(f"uuid[{i}] must be an integer 0..255, got {b!r}")
        return cls(bytes(octets), description)

    @classmethod
    def parse(cls, text: str, description: str | None = None) -> Id:
        """Parse a canonical uuid string; the description defaults to none."""
        if not _CANONICAL.match(text):
            raise IdError(f"not a canonical uuid string: {text!r}")
        return cls(_uuid.UUID(text).bytes, "" if description is None else description)

    @property
    def octets(self) -> list[int]:
        return list(self.uuid)


def canonical_uuid(octets: bytes) -> str:
    """Sixteen bytes as the canonical lower-case 8-4-4-4-12 uuid string."""
    h = octets.hex()
    return f"{h[:8]}-{h[8:12]}-{h[12:16]}-{h[16:20]}-{h[20:]}"


NIL = Id(bytes(16))


class NamedId(Id):
    """An :class:`Id` made by :func:`id_for`: its bytes are the stable id of its description.

    Equal to and hashed like any other Id with the same bytes; the class itself is the only difference. A
    trace writes such an id as its bare name (:mod:`vcran.io.render`), and finding out whether an arbitrary
    id is one meant hashing its description again: on a 1000-robot run that uuid5 per rendered id was a
    tenth of the CPU (the memo of :func:`id_for` cannot hold a big fleet's names).

    Only :func:`id_for` makes them: calling the class (as ``dataclasses.replace`` does) gives a plain Id,
    since nothing then vouches that the bytes belong to the description; a copy or a pickle is the
    name's id again.
    """

    __slots__ = ()

    def __new__(cls, uuid: bytes, description: str = "") -> Id:  # type: ignore[misc]
        return Id(uuid, description)

    def __reduce__(self) -> tuple[Any, tuple[str]]:
        return id_for, (self.description,)


def _named(uuid: bytes, name: str) -> Id:
    # The slots' own descriptors set the fields of the frozen instance: a third cheaper than
    # object.__setattr__, which looks the descriptor up on every call (one id per name of every cycle).
    ident = _new(NamedId)
    _set_uuid(ident, uuid)
    _set_description(ident, name)
    return ident


_new = object.__new__
_set_uuid = Id.__dict__["uuid"].__set__
_set_description = Id.__dict__["description"].__set__


@lru_cache(maxsize=4096)
def id_for(name: str) -> Id:
    """The stable id of a scenario name (module docstring); the name becomes the description."""
    if not isinstance(name, str) or not name:
        raise IdError(f"an id name must be a non-empty string, got {name!r}")
    return _named(_uuid.UUID(name).bytes if _CANONICAL.match(name) else uuid5_bytes(name), name)


def fresh_id(name: str) -> Id:
    """:func:`id_for` of a name vcran composed itself and will not ask for again (a script cycle's
    ``{prefix}_{k}_{i}_m{j}``), without the memo, which such names could only miss and, worse, fill,
    evicting the names a run does look up again (id_for on these names, uuid5 included, was a third of
    expanding a 1000-robot script; this removes the checks and the memo around the uuid5). A name with ``_`` is never a canonical uuid; any other goes through
    :func:`id_for`, so the result is always the same."""
    if "_" not in name:
        return id_for(name)
    ident = _new(NamedId)  # _named(uuid5_bytes(name), name), without its call (four names a task)
    _set_uuid(ident, uuid5_bytes(name))
    _set_description(ident, name)
    return ident


_NAMESPACE_SHA1 = hashlib.sha1(VCRAN_NAMESPACE.bytes, usedforsecurity=False)


def uuid5_bytes(name: str) -> bytes:
    """``uuid5(VCRAN_NAMESPACE, name).bytes`` from the namespace's pre-hashed SHA-1 state.

    A generated fleet names every task, motion and action of every cycle: hashing the namespace again
    for each, and building a ``uuid.UUID`` object to take its bytes, was most of what an id cost. The
    version and variant bits are set with one integer mask, not byte by byte in a bytearray (0.26 ->
    0.17 s per 300k names, micro-benchmark).
    """
    h = _NAMESPACE_SHA1.copy()
    h.update(name.encode("utf-8"))
    return ((int.from_bytes(h.digest()[:16]) & _UUID5_KEEP) | _UUID5_SET).to_bytes(16)


# RFC 4122: octet 6's high nibble is the version (5), octet 8's two high bits the variant (10).
_UUID5_KEEP = int.from_bytes(b"\xff" * 6 + b"\x0f\xff\x3f" + b"\xff" * 7)
_UUID5_SET = int.from_bytes(bytes(6) + b"\x50\x00\x80" + bytes(7))
