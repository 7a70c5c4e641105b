"""R9's history (vcran.core.opil.history.History): a byte log in age order with an open-addressing index.

Expectations are derived by hand from R9/R10 (the latest ``limit`` ids, oldest evicted first, a cancel
updating an entry without changing its age) and from the documented record size (25 bytes plus 8 per
assignment, 29 for 31 assignments or more, :data:`ENTRY_OVERHEAD` each, :data:`CANCEL_OVERHEAD` per remembered cancel); a stateful
comparison with an ordered dict covers long mixed sequences, with the index's hash forced to collide.
"""

from __future__ import annotations

from collections import OrderedDict

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vcran.core.opil import history as history_module
from vcran.core.opil.build import cancel, motion
from vcran.core.opil.effects import Reason
from vcran.core.opil.history import CANCEL_OVERHEAD, ENTRY_OVERHEAD, Ended, History, fingerprint
from vcran.core.opil.ids import id_for
from vcran.core.opil.tasks import Task


def ended(n_assignments: int, reason: Reason | None = None, t: float = 1.5, name: str = "T") -> Ended:
    task = Task(id_for(name), 0.0, 1, n_assignments, 30.0)
    for i in range(1, n_assignments + 1):
        task.put(motion(name, f"{name}_m{i}", i, n_assignments, float(i), 0.0), None)
    return Ended.of(task, reason, t)


def T(i: int):  # noqa: N802 - reads like the task ids of the other core tests
    return id_for(f"T{i}")


def small_chunks(monkeypatch) -> None:
    """Chunks of 64 bytes: one record of up to three assignments each, larger ones in chunks of their own."""
    monkeypatch.setattr(history_module, "CHUNK_BITS", 6)
    monkeypatch.setattr(history_module, "CHUNK", 64)
    monkeypatch.setattr(history_module, "_CHUNK_MASK", 63)


@pytest.fixture(params=["hash", "colliding", "small chunks"])
def hashing(request, monkeypatch):
    """The real hash; one sending every key to slot 0, so that every lookup walks a probe chain; and the real
    hash with chunks so small that every record starts a chunk (or is larger than one)."""
    if request.param == "colliding":
        monkeypatch.setattr(history_module, "_hash", lambda key: 0)
    elif request.param == "small chunks":
        small_chunks(monkeypatch)


def test_entry_round_trips_with_r10_identity(hashing):
    e = ended(3, Reason.TIMEOUT, 7.25)
    e.cancel = fingerprint(cancel("T"))
    history = History(limit=10, max_bytes=1 << 20)
    history.remember(id_for("T"), e)
    back = history.get(id_for("T"))
    assert (back.reason, back.time, back.received, back.cancel) == (Reason.TIMEOUT, 7.25, e.received, e.cancel)
    assert len(back.received) == 3 and all(len(f) == 8 for f in back.received)
    assert back.has_identical(motion("T", "T_m2", 2, 3, 2.0, 0.0, stamp=99.0))  # header ignored (R10)
    assert not back.has_identical(motion("T", "T_m2", 2, 3, 2.5, 0.0))
    assert back.same_cancel(cancel("T")) and not back.same_cancel(cancel("U"))
    assert history.get(id_for("U")) is None


def test_completed_task_without_assignments_round_trips(hashing):
    history = History(limit=10, max_bytes=1 << 20)
    history.remember(T(1), Ended(frozenset(), None, 3.0))
    back = history.get(T(1))
    assert (back.received, back.reason, back.time, back.cancel) == (frozenset(), None, 3.0, b"")
    assert not back.has_identical(motion("T1", "T1_m1", 1, 1, 1.0, 0.0))


def test_bounded_by_count_oldest_first(hashing):
    history = History(limit=2, max_bytes=1 << 30)
    for i in range(5):
        history.remember(T(i), ended(1, t=float(i)))
    assert list(history) == [T(3), T(4)] and len(history) == 2
    assert history.get(T(2)) is None and history.get(T(4)).time == 4.0


def test_bounded_by_bytes(hashing):
    per_entry = 16 + 8 + 1 + 8 + ENTRY_OVERHEAD  # uuid, time, reason and count in one byte, one fingerprint
    history = History(limit=100, max_bytes=3 * per_entry)
    for i in range(10):
        history.remember(T(i), ended(1))
    assert list(history) == [T(7), T(8), T(9)]
    # a remembered cancel costs CANCEL_OVERHEAD more: the oldest entries make room
    history.replace(T(9), Ended(frozenset(), None, 0.0, fingerprint(cancel("T9"))))
    assert list(history) == [T(7), T(8), T(9)]  # replace never evicts
    history.remember(T(10), ended(1))
    # 3 * 49 + 128 = 275 bytes, over the bound but replace never evicts; T10 makes it 324: T7 and T8
    # go (226), then T9 with its cancel (177 bytes, alone above the bound of 147)
    assert list(history) == [T(10)]


def test_byte_bound_keeps_the_newest_entry_however_large(hashing):
    history = History(limit=100, max_bytes=10)
    history.remember(T(1), ended(1))
    history.remember(T(2), ended(4))
    assert list(history) == [T(2)] and len(history.get(T(2)).received) == 4


def test_replace_keeps_age(hashing):
    history = History(limit=3, max_bytes=1 << 20)
    for i in range(3):
        history.remember(T(i), ended(2, Reason.CANCELLED, float(i)))
    first = history.get(T(0))
    first.cancel = fingerprint(cancel("T0"))
    history.replace(T(0), first)
    assert list(history) == [T(0), T(1), T(2)]
    assert history.get(T(0)).same_cancel(cancel("T0")) and history.get(T(0)).received == first.received
    history.remember(T(3), ended(1))  # T0 is still the oldest: it goes first
    assert list(history) == [T(1), T(2), T(3)] and history.get(T(0)) is None
    with pytest.raises(KeyError):
        history.replace(T(0), first)


def test_remembering_an_id_twice_is_refused(hashing):
    history = History(limit=3, max_bytes=1 << 20)
    history.remember(T(1), ended(1))
    with pytest.raises(ValueError, match="already in the history"):
        history.remember(T(1), ended(1))


def test_evicted_slots_are_reused_without_hiding_later_keys(hashing):
    """With every key on one probe chain, an insertion into an evicted entry's slot must not hide the
    entries further along the chain, and the evicted key must stay forgotten."""
    history = History(limit=3, max_bytes=1 << 20)
    for i in range(200):  # many evictions: log cuts and index rebuilds on the way
        history.remember(T(i), ended(1 + i % 3, t=float(i)))
        assert list(history) == [T(j) for j in range(max(0, i - 2), i + 1)]
        assert all(history.get(T(j)).time == float(j) for j in range(max(0, i - 2), i + 1))
        assert all(history.get(T(j)) is None for j in range(max(0, i - 6), max(0, i - 2)))


@st.composite
def operations(draw):
    ops = draw(st.lists(st.tuples(st.sampled_from(["remember", "replace", "get"]), st.integers(0, 30),
                                  st.integers(0, 3), st.booleans()), max_size=150))
    return draw(st.integers(1, 12)), draw(st.sampled_from([1 << 20, 300, 120])), ops


@settings(max_examples=60, deadline=None)
@given(operations(), st.booleans(), st.booleans())
def test_agrees_with_an_ordered_dict(case, colliding, small):
    limit, max_bytes, ops = case
    saved = history_module._hash, history_module.CHUNK_BITS, history_module.CHUNK, history_module._CHUNK_MASK
    if colliding:
        history_module._hash = lambda key: key[0] % 3  # three chains
    if small:  # 128-byte chunks: three records of one assignment, two of two or three; larger ones alone
        history_module.CHUNK_BITS, history_module.CHUNK, history_module._CHUNK_MASK = 7, 128, 127
    try:
        history = History(limit, max_bytes)
        model: OrderedDict[bytes, Ended] = OrderedDict()

        def cost(e: Ended) -> int:
            return 25 + 8 * len(e.received) + ENTRY_OVERHEAD + (CANCEL_OVERHEAD if e.cancel else 0)

        for k, (op, i, n, with_cancel) in enumerate(ops):
            key = T(i)
            if op == "remember" and key.uuid not in model:
                e = ended(n, None if n == 0 else Reason.TIMEOUT, float(k), name=f"T{i}")
                if with_cancel:
                    e.cancel = fingerprint(cancel(f"T{i}", motion=f"m{k}"))
                history.remember(key, e)
                model[key.uuid] = e
                while len(model) > limit or (sum(map(cost, model.values())) > max_bytes and len(model) > 1):
                    model.popitem(last=False)
            elif op == "replace" and key.uuid in model:
                e = model[key.uuid]
                e = Ended(e.received, e.reason, e.time, fingerprint(cancel(f"T{i}", action=f"a{k}")) if with_cancel else b"")
                history.replace(key, e)
                model[key.uuid] = e
            got = history.get(key)
            want = model.get(key.uuid)
            assert (got is None) == (want is None)
            if want is not None:
                assert (got.received, got.reason, got.time, got.cancel) == (want.received, want.reason, want.time, want.cancel)
            assert [i.uuid for i in history] == list(model) and len(history) == len(model)
    finally:
        history_module._hash, history_module.CHUNK_BITS, history_module.CHUNK, history_module._CHUNK_MASK = saved


def test_evictions_do_not_grow_the_log_or_the_index(hashing):
    """Evicted records are dropped from the log and their index slots reused or dropped: memory follows
    the live entries, not how many ever ended."""
    history = History(limit=3, max_bytes=1 << 20)
    for i in range(2000):
        history.remember(T(i), ended(1))
        # three live records span at most three chunks (one each when chunks are small), and the dead
        # chunks in front are dropped as soon as they are as many as the live ones: at most 2 + 3
        assert len(history._chunks) <= 5
    assert len(history._index) <= 16


def test_records_larger_than_a_chunk_get_one_of_their_own():
    # 25 + 4 + 8 * 600 bytes (a count of 31 or more takes 4 bytes more): more than a 4096-byte chunk
    history = History(limit=4, max_bytes=1 << 20)
    history.remember(T(1), ended(1, t=1.0))
    history.remember(T(2), ended(600, t=2.0, name="T2"))
    history.remember(T(3), ended(2, t=3.0))
    # the first chunk (256 bytes) is cut to its one record when the next does not fit; the third is 1 KiB
    assert [len(c) for c in history._chunks] == [25 + 8, 29 + 8 * 600, 1024]
    assert [history.get(T(i)).time for i in (1, 2, 3)] == [1.0, 2.0, 3.0]
    assert len(history.get(T(2)).received) == 600 and list(history) == [T(1), T(2), T(3)]
    for i in (4, 5, 6):
        history.remember(T(i), ended(1, t=float(i)))
    assert list(history) == [T(3), T(4), T(5), T(6)] and history.get(T(2)) is None


@pytest.mark.parametrize("n", [0, 1, 30, 31, 32, 300])
def test_any_number_of_fingerprints_round_trips(n, hashing):
    # 30 fit the record's one byte beside the reason; from 31 on a 4-byte count follows it
    history = History(limit=10, max_bytes=1 << 20)
    e = ended(n, Reason.COLLISION, 4.5, name="N")
    history.remember(id_for("N"), e)
    history.remember(T(1), ended(2, Reason.CANCELLED, 5.0))
    back, after = history.get(id_for("N")), history.get(T(1))
    assert (back.received, back.reason, back.time) == (e.received, Reason.COLLISION, 4.5) and len(back.received) == n
    assert (after.reason, after.time, len(after.received)) == (Reason.CANCELLED, 5.0, 2)
    assert history._bytes == (25 + (4 if n >= 31 else 0) + 8 * n) + (25 + 16) + 2 * ENTRY_OVERHEAD
