"""Cheaper construction paths (issue 14 item 5) give exactly what the checked paths give."""

from __future__ import annotations

import dataclasses
import uuid

import pytest
from hypothesis import given
from hypothesis import strategies as st

from vcran.core.ids import VCRAN_NAMESPACE, id_for, uuid5_bytes
from vcran.core.messages import Header, MotionAssignment, RanStatus, Sequence, Time
from vcran.core.schema import MessageError, unchecked
from vcran.testing.strategies import attribute_messages


@given(st.text(min_size=1))
def test_uuid5_from_prehashed_state_is_rfc4122_uuid5(name):  # docs/ids.md: the mapping never changes
    assert uuid5_bytes(name) == uuid.uuid5(VCRAN_NAMESPACE, name).bytes


def test_id_for_known_value():  # pinned by hand: python -c "uuid.uuid5(uuid.uuid5(NAMESPACE_URL, URL), 'robot_1')"
    expected = uuid.uuid5(uuid.uuid5(uuid.NAMESPACE_URL, "https://github.com/vcran/vcran/ids"), "robot_1")
    assert id_for("robot_1").uuid == expected.bytes


@given(attribute_messages())
def test_unchecked_constructor_builds_the_same_message(pair):
    _, message = pair
    values = {f.name: getattr(message, f.name) for f in dataclasses.fields(message)}
    copy = unchecked(type(message))(**values)
    assert type(copy) is type(message)
    assert copy == message


def test_unchecked_defaults_match_the_dataclass():
    assert unchecked(RanStatus)() == RanStatus()
    assert unchecked(MotionAssignment)() == MotionAssignment()
    assert unchecked(Header)(seq=3).stamp == Time()


def test_unchecked_skips_validation_and_the_checked_path_does_not():
    with pytest.raises(MessageError):
        Sequence(5, 1)
    assert unchecked(Sequence)(5, 1).sequence_number == 5


def test_time_from_seconds_still_refuses_what_int32_cannot_hold():
    assert Time.from_seconds(1.5) == Time(1, 500_000_000)
    with pytest.raises(MessageError):
        Time.from_seconds(2.0**31)


# --- R9 history: compact records, bounded by count and bytes ---------------------------------------------


def _ended(n_assignments: int, reason=None, t=1.5):
    from vcran.core.build import motion
    from vcran.core.tasks import Ended, Task

    task = Task(id_for("T"), 0.0, 1, n_assignments, 30.0)
    for i in range(1, n_assignments + 1):
        task.put(motion("T", f"T_m{i}", i, n_assignments, float(i), 0.0), None)
    return Ended.of(task, reason, t)


def test_history_record_round_trips_and_keeps_r10_identity():
    from vcran.core.build import cancel, motion
    from vcran.core.effects import Reason
    from vcran.core.tasks import Ended, fingerprint

    ended = _ended(3, Reason.TIMEOUT, 7.25)
    ended.cancel = fingerprint(cancel("T"))
    back = Ended.from_record(ended.record())
    assert (back.reason, back.time, back.received) == (Reason.TIMEOUT, 7.25, ended.received)
    assert len(ended.record()) == 8 + 1 + 16 + 3 * 16  # fixed part plus one fingerprint per assignment
    assert back.has_identical(motion("T", "T_m2", 2, 3, 2.0, 0.0, stamp=99.0))  # header ignored (R10)
    assert not back.has_identical(motion("T", "T_m2", 2, 3, 2.5, 0.0))
    assert back.same_cancel(cancel("T")) and not back.same_cancel(cancel("U"))


def test_history_is_bounded_by_count_and_by_bytes():
    from vcran.core.tasks import ENTRY_OVERHEAD, History

    small = _ended(1)
    per_entry = len(small.record()) + ENTRY_OVERHEAD
    history = History(limit=100, max_bytes=3 * per_entry)
    for i in range(10):
        history.remember(id_for(f"T{i}"), small)
    assert list(history) == [id_for("T7"), id_for("T8"), id_for("T9")]  # the byte bound: three entries
    by_count = History(limit=2, max_bytes=1 << 30)
    for i in range(5):
        by_count.remember(id_for(f"T{i}"), small)
    assert list(by_count) == [id_for("T3"), id_for("T4")]
    assert by_count.get(id_for("T2")) is None and by_count.get(id_for("T4")) is not None


@given(
    st.lists(st.tuples(st.floats(-50, 50), st.floats(-50, 50), st.none() | st.floats(-3, 3)), max_size=4),
    st.lists(st.sampled_from(["load", "unload", "dummy"]), max_size=3),
    st.floats(0, 2, allow_subnormal=False), st.floats(0, 1e5),
)
def test_repeated_task_is_the_task_built_again_under_its_new_name_and_stamp(path, actions, speed, stamp):
    from vcran.core import build
    from vcran.core.messages import ActionAssignment

    if not path and not actions:
        actions = ["dummy"]
    first = build.task("c_0_1", path, actions, max_velocity=speed, stamp=3.0)
    again = build.repeated(first, "c_7_1", stamp)
    assert again == build.task("c_7_1", path, actions, max_velocity=speed, stamp=stamp)
    # names too, not only what __eq__ compares (an Id compares by uuid)
    motions = [m.motion_id.description for m in again if isinstance(m, MotionAssignment)]
    assert motions == [f"c_7_1_m{i}" for i in range(1, len(path) + 1)]
    assert [a.action_id.description for a in again if isinstance(a, ActionAssignment)] == \
        [f"c_7_1_a{j}" for j in range(1, len(actions) + 1)]
