"""R9's history: what one robot remembers of the tasks that ended, and how little it may cost.

An ended task keeps only what R9 and R10 still ask of it: its id, when and why it ended, and an 8-byte
fingerprint of each of its assignments and of its last cancel (:func:`fingerprint`), so that a re-read
of one stays silent. :class:`History` holds them per robot in a byte log with an open-addressing index,
bounded by count (``history_limit``) and by memory (``history_bytes``); RanLogic asks it when an id it
does not queue is seen again (:mod:`vcran.core.opil.ranlogic`).
"""

from __future__ import annotations

import io
import pickle
import struct
import threading
from array import array
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from hashlib import blake2b
from typing import TYPE_CHECKING, Any

from vcran.core.opil.effects import Reason
from vcran.core.opil.ids import Id
from vcran.core.opil.messages import Assignment, CancelTask
from vcran.core.opil.schema import specs

if TYPE_CHECKING:
    from vcran.core.opil.tasks import Task

#: (message class, field left out) -> its flattener (:func:`_flattener`).
_FLATTENERS: dict[tuple[type, str], Callable[[Any], tuple[Any, ...]]] = {}
#: Float fields are flattened as ``v + 0.0``, which turns -0.0 into 0.0: R10 compares numbers (-0.0 == 0.0),
#: so the fingerprint must not tell the signs of a zero apart (pickle would).
_FLOATS = ("float64", "float32")


def _flattener(cls: type, skip: str = "") -> Callable[[Any], tuple[Any, ...]]:
    """A function returning every primitive of a ``cls`` in schema order, ids by their uuid only
    (docs/contract.md §2), zeros unsigned, without the field ``skip``. Generated once per class from :func:`specs`: a generic walk
    costs several times more, and this runs for every assignment of every ended task."""
    key = (cls, skip)
    found = _FLATTENERS.get(key)
    if found is not None:
        return found
    helpers: dict[str, Any] = {}
    parts: list[str] = []

    def walk(c: type, path: str, omit: str = "") -> None:
        for spec in specs(c):
            if spec.name == omit:
                continue
            here = f"{path}.{spec.name}"
            if spec.kind == "prim":
                parts.append(f"({here} + 0.0)" if spec.ros in _FLOATS else here)
            elif spec.kind == "id":
                parts.append(f"{here}.uuid")
            elif spec.kind == "msg":
                walk(spec.cls, here)  # type: ignore[arg-type]
            else:
                name = f"_a{len(helpers)}"
                # (an empty array, the usual motion area, makes no generator)
                if spec.cls is None and spec.ros[:-2] in _FLOATS:
                    helpers[name] = lambda items: (len(items), *(v + 0.0 for v in items)) if items else (0,)
                elif spec.cls is None:
                    helpers[name] = lambda items: (len(items), *items)
                elif spec.cls is Id:
                    helpers[name] = lambda items: (len(items), *(i.uuid for i in items)) if items else (0,)
                else:
                    inner = _flattener(spec.cls)
                    helpers[name] = (lambda items, inner=inner:
                                     (len(items), *(v for i in items for v in inner(i))) if items else (0,))
                parts.append(f"*{name}({here})")

    walk(cls, "m", skip)
    found = eval(f"lambda m: ({', '.join(parts)},)", helpers)  # noqa: S307 - source built from specs only
    _FLATTENERS[key] = found
    return found


#: Bytes of a :func:`fingerprint`.
FINGERPRINT_SIZE = 8


def fingerprint(a: Assignment | CancelTask) -> bytes:
    """An 8-byte digest of what :func:`same_content` compares: the kind and every field but the header.

    Ended tasks keep these instead of their assignments, so the R9 history costs 8 bytes per
    assignment, not a kilobyte. Deterministic (no salted ``hash()``): the schema-ordered primitives are
    pickled (floats and bytes pickle exactly) and hashed with blake2b, a keyless uniform hash.

    Why 8 bytes are enough: a fingerprint is only ever compared with those of one ended task (its n
    assignments, or its last cancel), never looked up fleet-wide, so the birthday bound does not apply.
    An assignment that differs from all n matches one of them with probability n * 2**-64 (5e-19 for a
    three-assignment task); a million robots re-reading a changed assignment of an ended task every
    second for a year (3e13 comparisons) would meet one collision with probability below 1e-5. And the
    cost of one is small: a re-read that should have been reported (R9 ``task_completed``/``task_cancelled``)
    goes silent; an ended task applies nothing either way.
    """
    cls = type(a)
    flat = _FLATTENERS.get((cls, "header"))  # only MotionAssignment has one
    if flat is None:
        flat = _flattener(cls, "header")
    return blake2b(_pickled((cls.__name__, *flat(a))), digest_size=FINGERPRINT_SIZE).digest()


_PICKLERS = threading.local()


def _pickled(content: tuple[Any, ...]) -> bytes:
    """``content`` pickled without pickle's memo: with it, a bytes or str object met twice is written the
    second time as a reference to the first, so equal contents held by one object or by two equal ones
    (a built motion's point_id and motion_id are one Id; decoded from the wire they are two) pickled, and
    hashed, differently. Without it the bytes depend on the values alone (a flat tuple: no cycles). One
    pickler per thread, reused: making one per call took fingerprint() from 2.1 to 2.8 µs, reusing it 2.2."""
    try:
        out, pickler = _PICKLERS.pair
    except AttributeError:
        out = io.BytesIO()
        pickler = pickle.Pickler(out, protocol=5)
        pickler.fast = True  # no memo
        _PICKLERS.pair = out, pickler
    out.seek(0)
    out.truncate()
    pickler.dump(content)
    return out.getvalue()


_REASONS: tuple[Reason | None, ...] = (None, *Reason)
assert len(_REASONS) <= 8, "a history record holds the reason in three bits (_record_head)"
_NO_CANCEL = b""
#: A history record's fixed part: task uuid, end time, and one byte holding the reason (0: completed) in its
#: low three bits and the number of fingerprints in its high five; ``_MANY`` there says a 4-byte count
#: follows (a task of 31 assignments or more).
_HEAD = struct.Struct("<16sdB")
_MANY = 31
_COUNT = struct.Struct("<I")
#: The history's log is kept in chunks of 2**CHUNK_BITS bytes (:class:`History`).
CHUNK_BITS = 12
CHUNK = 1 << CHUNK_BITS
_CHUNK_MASK = CHUNK - 1
#: What one history entry costs besides its record, in the unit of the memory bound (``history_bytes``):
#: its share of the index (a 4-byte slot at a load between 1/3 and 2/3) and of the log's spare capacity.
ENTRY_OVERHEAD = 16
#: Where a key's probe sequence starts in the index (a name of its own so that tests can force collisions).
_hash = hash
#: What a remembered cancel costs on top (an entry of a small dict: key and value objects, slot).
CANCEL_OVERHEAD = 128


@dataclass(slots=True, eq=False)
class Ended:
    """A finished task in the history (R9), or a tombstone left by a cancel for an unknown id (R8).

    It keeps only what R9 and R10 still ask of an ended task: the fingerprints of its assignments, so
    that a re-read of one of them stays silent, and the fingerprint of its last cancel. The
    :class:`History` stores it as a record in a byte log and decodes this view only when an id of an
    ended task is seen again.
    """

    received: frozenset[bytes]
    reason: Reason | None  # None: completed
    time: float
    #: Fingerprint of the last cancel received for this id, so that re-reads of it stay silent (R10);
    #: empty if none was.
    cancel: bytes = _NO_CANCEL

    @classmethod
    def of(cls, task: Task | None, reason: Reason | None, time: float, cancel: CancelTask | None = None) -> Ended:
        received = frozenset(map(fingerprint, task.slots.values())) if task is not None else frozenset()
        return cls(received, reason, time, fingerprint(cancel) if cancel is not None else _NO_CANCEL)

    def has_identical(self, a: Assignment) -> bool:
        """R10: ``a`` is a re-read of one of the task's assignments."""
        return bool(self.received) and fingerprint(a) in self.received

    def same_cancel(self, cancel: CancelTask) -> bool:
        return self.cancel == fingerprint(cancel)


class History:
    """R9: the ended task ids of one robot, oldest first, bounded by count and by memory.

    A long run ends tens of thousands of tasks per robot-hour at fleet scale, and the default bound
    (10,000 per robot) is hours away, so every byte per entry shows in the run's peak memory. Python
    objects per entry (a bytes record, a bytes key, a dict slot, a deque slot) cost about 0.2 kB, and
    spread over the allocator's pools they kept even more resident. Here an entry is one record in a
    per-robot byte log, in age order: the task's uuid, end time, reason and the 8-byte fingerprints of
    its assignments (:data:`_HEAD` plus 8 per assignment: 49 bytes for a task of three).

    The log is a list of chunks of up to :data:`CHUNK` bytes, each allocated once at its full size: one
    growing buffer per robot was reallocated and copied as it grew, and across a fleet's buffers the
    allocator kept about 20 bytes per entry resident beyond the records (a 1000-robot run, issue 14).
    A record never straddles two chunks (one larger than :data:`CHUNK` gets a chunk of its own), so an
    offset is a chunk's number times :data:`CHUNK` plus a position in it, and offsets grow with age.
    Eviction moves the start of the live records; the dead chunks in front are dropped once they are
    as many as the live ones (amortised O(1)).

    Lookups go through an open-addressing index: a power-of-two array of ``offset + 1`` (0: empty),
    linear probing from ``hash(uuid)`` (salted per process, which moves only where a slot is, never
    what a lookup answers). Slots of evicted records (offset before the live start) are reused by
    insertions and dropped when the index is rebuilt, which happens when it grows past 2/3 full or
    when chunks are dropped. Cancels of ended tasks are rare and stored in a small dict beside it (a
    later cancel must update an entry in place, :meth:`replace`).

    ``limit`` is R9's count (``history_limit``); ``max_bytes`` bounds the records plus
    :data:`ENTRY_OVERHEAD` each (and :data:`CANCEL_OVERHEAD` per remembered cancel), so that tasks
    with very many assignments cannot grow it without end.
    """

    __slots__ = ("limit", "max_bytes", "_chunks", "_fill", "_head", "_count", "_bytes", "_index", "_used",
                 "_cancels")

    def __init__(self, limit: int, max_bytes: int) -> None:
        self.limit, self.max_bytes = limit, max_bytes
        self._chunks: list[bytearray] = []
        self._fill = 0  # bytes used in the last chunk (a closed chunk is cut to its records' length)
        self._head = 0  # offset of the oldest live record; before it, evicted ones not yet dropped
        self._count = 0
        self._bytes = 0
        #: Index slots hold ``offset + 1``; 4 bytes each while offsets stay below 4 GiB (the dead front is at
        #: most as long as the live records, which a memory bound below 1 GiB keeps well under 2 GiB).
        self._index = array("I" if max_bytes < 1 << 30 else "Q", [0]) * 8
        self._used = 0  # slots not empty (live or stale)
        self._cancels: dict[bytes, bytes] = {}

    def __len__(self) -> int:
        return self._count

    def __iter__(self) -> Iterator[Id]:
        """The remembered task ids, oldest first (as ids without description: only the uuid is kept)."""
        return (Id(self._key_at(offset)) for offset in self._offsets())

    def get(self, task_id: Id) -> Ended | None:
        offset = self._find(task_id.uuid)
        if offset < 0:
            return None
        chunk = self._chunks[offset >> CHUNK_BITS]
        time, reason, n, start = _read_head(chunk, offset & _CHUNK_MASK)
        received = frozenset(bytes(chunk[i:i + FINGERPRINT_SIZE])
                             for i in range(start, start + n * FINGERPRINT_SIZE, FINGERPRINT_SIZE))
        return Ended(received, _REASONS[reason], time, self._cancels.get(task_id.uuid, _NO_CANCEL))

    def remember(self, task_id: Id, ended: Ended) -> None:
        """Add ``task_id`` as the newest entry; it must not be in the history (RanLogic looks first)."""
        key = task_id.uuid
        if self._find(key) >= 0:
            raise ValueError(f"task {task_id.label} is already in the history")
        record = _record_head(key, ended.time, _REASONS.index(ended.reason), len(ended.received))
        record += b"".join(sorted(ended.received))
        offset = self._append(record)
        if not self._count:
            self._head = offset
        self._count += 1
        self._bytes += len(record) + ENTRY_OVERHEAD
        if ended.cancel or self._cancels:  # else _set_cancel changes nothing (an entry just made has none)
            self._set_cancel(key, ended.cancel)
        self._insert(key, offset)
        while self._count > self.limit or (self._bytes > self.max_bytes and self._count > 1):
            self._evict_oldest()

    def replace(self, task_id: Id, ended: Ended) -> None:
        """Update an entry in place (a later cancel of an ended task), keeping its age.

        Only the cancel can change: the rest of an ended task is final."""
        if self._find(task_id.uuid) < 0:
            raise KeyError(task_id)
        self._set_cancel(task_id.uuid, ended.cancel)

    # --- the log ----------------------------------------------------------------------------------------

    def _append(self, record: bytes) -> int:
        """Write ``record`` after the newest one, in a new chunk if it does not fit; return its offset."""
        chunk = self._chunks[-1] if self._chunks else None
        if chunk is None or self._fill + len(record) > len(chunk):
            if chunk is not None:
                del chunk[self._fill:]  # closed: its length is its records' (a short cut: not reallocated)
            # the first chunks are smaller (256 bytes, then twice as many each): a robot that ends few tasks
            # (a test, a short run, a big fleet's idle robots) does not hold 4 KiB for them
            chunk = bytearray(max(min(CHUNK, 256 << len(self._chunks)), len(record)))
            self._chunks.append(chunk)
            self._fill = 0
        offset = ((len(self._chunks) - 1) << CHUNK_BITS) + self._fill
        chunk[self._fill:self._fill + len(record)] = record
        self._fill += len(record)
        return offset

    def _key_at(self, offset: int) -> bytes:
        pos = offset & _CHUNK_MASK
        return bytes(self._chunks[offset >> CHUNK_BITS][pos:pos + 16])

    def _size_at(self, offset: int) -> int:
        pos = offset & _CHUNK_MASK
        _, _, n, start = _read_head(self._chunks[offset >> CHUNK_BITS], pos)
        return start - pos + FINGERPRINT_SIZE * n

    def _after(self, offset: int) -> int:
        """The offset of the record after the one at ``offset``: past a chunk's last record, the next chunk's start."""
        i = offset >> CHUNK_BITS
        pos = (offset & _CHUNK_MASK) + self._size_at(offset)
        end = self._fill if i == len(self._chunks) - 1 else len(self._chunks[i])
        return (i << CHUNK_BITS) + pos if pos < end else (i + 1) << CHUNK_BITS

    def _offsets(self) -> Iterator[int]:
        offset = self._head
        for _ in range(self._count):
            yield offset
            offset = self._after(offset)

    def _set_cancel(self, key: bytes, cancel: bytes) -> None:
        had = key in self._cancels
        if cancel:
            self._cancels[key] = cancel
        else:
            self._cancels.pop(key, None)
        self._bytes += ((cancel != _NO_CANCEL) - had) * CANCEL_OVERHEAD

    def _evict_oldest(self) -> None:
        offset = self._head
        size = self._size_at(offset)
        self._set_cancel(self._key_at(offset), _NO_CANCEL)
        self._head = self._after(offset)
        self._count -= 1
        self._bytes -= size + ENTRY_OVERHEAD
        dead = self._head >> CHUNK_BITS
        if dead and dead >= len(self._chunks) - dead:  # as many dead chunks in front as live ones: drop them
            del self._chunks[:dead]
            self._head -= dead << CHUNK_BITS
            self._rebuild()

    # --- the index --------------------------------------------------------------------------------------

    def _find(self, key: bytes) -> int:
        """The offset of ``key``'s record, or -1."""
        index, chunks, head = self._index, self._chunks, self._head
        mask = len(index) - 1
        i = _hash(key) & mask
        while slot := index[i]:
            offset = slot - 1
            if offset >= head:
                pos = offset & _CHUNK_MASK
                if chunks[offset >> CHUNK_BITS][pos:pos + 16] == key:
                    return offset
            i = (i + 1) & mask
        return -1

    def _insert(self, key: bytes, offset: int) -> None:
        """Point a slot at ``offset``: the first empty one or stale one (an evicted record's) on ``key``'s probe
        sequence; ``key`` is not in the index, so no later slot of the sequence can hold it."""
        index, head = self._index, self._head
        mask = len(index) - 1
        i = _hash(key) & mask
        while (slot := index[i]) and slot - 1 >= head:
            i = (i + 1) & mask
        if not slot:
            self._used += 1
        index[i] = offset + 1
        if 3 * self._used > 2 * len(index):  # live and stale slots: rebuilt for the live ones
            self._rebuild()

    def _rebuild(self) -> None:
        """A fresh index holding the live records only: the smallest power of two (8 at least) that they fill
        to 1/3 at most. Stale slots do not make it grow: memory follows the live entries."""
        size = 8
        while 3 * self._count > size:
            size *= 2
        self._index = array(self._index.typecode, [0]) * size
        self._used = 0
        for offset in self._offsets():
            self._insert(self._key_at(offset), offset)


def _record_head(key: bytes, time: float, reason: int, n: int) -> bytes:
    if n < _MANY:
        return _HEAD.pack(key, time, reason | n << 3)
    return _HEAD.pack(key, time, reason | _MANY << 3) + _COUNT.pack(n)


def _read_head(buf: bytearray, pos: int) -> tuple[float, int, int, int]:
    """The end time, reason index and number of fingerprints of the record at ``pos``, and where they start."""
    _, time, meta = _HEAD.unpack_from(buf, pos)
    n, start = meta >> 3, pos + _HEAD.size
    if n == _MANY:
        n = _COUNT.unpack_from(buf, start)[0]
        start += _COUNT.size
    return time, meta & 7, n, start
