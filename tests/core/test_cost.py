"""Cheaper construction paths (issue 14 item 5) give exactly what the checked paths give."""

from __future__ import annotations

import dataclasses
import uuid

import pytest
from hypothesis import given
from hypothesis import strategies as st

from vcran.core.opil.ids import VCRAN_NAMESPACE, NamedId, fresh_id, id_for, uuid5_bytes
from vcran.core.opil.messages import Header, MotionAssignment, RanStatus, Sequence, Time
from vcran.core.opil.schema import MessageError
from vcran.core.slots import unchecked
from vcran.testing.strategies import attribute_messages


@given(st.text(min_size=1))
def test_uuid5_from_prehashed_state_is_rfc4122_uuid5(name):  # docs/ids.md: the mapping never changes
    assert uuid5_bytes(name) == uuid.uuid5(VCRAN_NAMESPACE, name).bytes


def test_id_for_known_value():  # pinned by hand: python -c "uuid.uuid5(uuid.uuid5(NAMESPACE_URL, URL), 'robot_1')"
    expected = uuid.uuid5(uuid.uuid5(uuid.NAMESPACE_URL, "https://github.com/vcran/vcran/ids"), "robot_1")
    assert id_for("robot_1").uuid == expected.bytes


@given(st.one_of(st.text(min_size=1), st.uuids().map(str), st.uuids().map(lambda u: str(u).upper())))
def test_fresh_id_is_id_for(name):  # docs/ids.md: skipping the memo must not change the mapping
    fresh = fresh_id(name)
    assert fresh == id_for(name) and type(fresh) is type(id_for(name))
    assert fresh.description == id_for(name).description


def test_fresh_id_of_a_composed_name_is_a_named_id_without_touching_the_memo():
    id_for.cache_clear()
    assert isinstance(fresh_id("cycle_3_1_m2"), NamedId)
    assert id_for.cache_info().currsize == 0


@pytest.mark.slow
@given(attribute_messages())
def test_unchecked_constructor_builds_the_same_message(pair):
    _, message = pair
    values = {f.name: getattr(message, f.name) for f in dataclasses.fields(message)}
    copy = unchecked(type(message))(**values)
    assert type(copy) is type(message)
    assert copy == message and hash(copy) == hash(message) and repr(copy) == repr(message)
    with pytest.raises(dataclasses.FrozenInstanceError):  # the slot setters bypass frozen only while building
        setattr(copy, dataclasses.fields(copy)[0].name, None)


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


@given(
    st.lists(st.tuples(st.floats(-50, 50), st.floats(-50, 50), st.none() | st.floats(-3, 3)), max_size=4),
    st.lists(st.sampled_from(["load", "unload", "dummy"]), max_size=3),
    st.floats(0, 2, allow_subnormal=False), st.floats(0, 1e5),
)
def test_repeated_task_is_the_task_built_again_under_its_new_name_and_stamp(path, actions, speed, stamp):
    from vcran.core.opil import build
    from vcran.core.opil.messages import ActionAssignment

    if not path and not actions:
        actions = ["dummy"]
    first = build.task("c_0_1", path, actions, max_velocity=speed, stamp=3.0)
    again = build.RepeatedTasks([first]).build(["c_7_1"], build.header_at(stamp))
    assert again == build.task("c_7_1", path, actions, max_velocity=speed, stamp=stamp)
    # names too, not only what __eq__ compares (an Id compares by uuid)
    motions = [m.motion_id.description for m in again if isinstance(m, MotionAssignment)]
    assert motions == [f"c_7_1_m{i}" for i in range(1, len(path) + 1)]
    assert [a.action_id.description for a in again if isinstance(a, ActionAssignment)] == \
        [f"c_7_1_a{j}" for j in range(1, len(actions) + 1)]


def test_slot_init_keeps_the_dataclass_constructor_behaviour():  # issue 14 item 5: faster __init__, same record
    from vcran.core.slots import slot_init

    def record(fast):
        @dataclasses.dataclass(frozen=True, slots=True)
        class Record:
            t: float
            tags: list = dataclasses.field(default_factory=list)
            note: str = "n"

            def __post_init__(self):
                if self.t < 0:
                    raise ValueError("t")
        return slot_init(Record) if fast else Record

    fast, plain = record(True), record(False)
    assert fast.__init__ is not plain.__init__
    a, b = fast(1.0), plain(1.0)
    assert (a.t, a.tags, a.note) == (b.t, b.tags, b.note) == (1.0, [], "n")
    assert fast(2.0).tags is not fast(2.0).tags  # a fresh default per instance, as the dataclass makes
    assert fast(1.0, note="x") == fast(1.0, note="x")
    assert repr(fast(1.0)).endswith("Record(t=1.0, tags=[], note='n')")
    with pytest.raises(ValueError):  # __post_init__ still runs
        fast(-1.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        a.t = 3.0


def test_slot_init_keeps_keyword_only_fields_keyword_only():  # issue 31: VDA 5050's models are kw_only
    from vcran.core.slots import slot_init

    def record(fast):
        @dataclasses.dataclass(frozen=True, slots=True)
        class Record:
            t: float
            note: str = "n"
            tags: list = dataclasses.field(default_factory=list, kw_only=True)
            level: int = dataclasses.field(kw_only=True)  # required, after defaults: keyword-only allows it
        return slot_init(Record) if fast else Record

    fast, plain = record(True), record(False)
    for make in (fast, plain):
        a = make(1.0, level=2)
        assert (a.t, a.note, a.tags, a.level) == (1.0, "n", [], 2)
        assert make(1.0, "x", level=3, tags=[1]) == make(t=1.0, note="x", tags=[1], level=3)
        with pytest.raises(TypeError):  # level is keyword-only
            make(1.0, "x", [], 2)
        with pytest.raises(TypeError):  # and required
            make(1.0)


def test_repeated_tasks_are_built_again_under_their_names_with_one_header():  # issue 14 item 5
    from vcran.core.opil import build

    a = build.task("c_0_1", [(1.0, 2.0), (3.0, 4.0, 0.5)], ["load"], max_velocity=1.5, stamp=2.0)
    b = build.task("c_0_2", [(5.0, 6.0)], ["unload", "dummy"], stamp=2.0)
    again = build.RepeatedTasks([a, b]).build(["c_3_1", "c_3_2"], build.header_at(9.5))
    assert again == [*build.task("c_3_1", [(1.0, 2.0), (3.0, 4.0, 0.5)], ["load"], max_velocity=1.5, stamp=9.5),
                     *build.task("c_3_2", [(5.0, 6.0)], ["unload", "dummy"], stamp=9.5)]
    names = [(m.task_id.description, (m.motion_id if isinstance(m, MotionAssignment) else m.action_id).description)
             for m in again]
    assert names == [("c_3_1", "c_3_1_m1"), ("c_3_1", "c_3_1_m2"), ("c_3_1", "c_3_1_a1"),
                     ("c_3_2", "c_3_2_m1"), ("c_3_2", "c_3_2_a1"), ("c_3_2", "c_3_2_a2")]
    assert again[0].header is again[3].header  # one header per repetition
    with pytest.raises(ValueError):
        build.RepeatedTasks([a, b]).build(["c_3_1"], build.header_at(9.5))  # a name per task


@pytest.mark.parametrize("first", [0.0, -0.0])
def test_shared_parts_keep_the_sign_of_zero_whatever_was_built_before(first):
    # docs/contract.md §5: the parts build shares (points, limits, areas) are keyed by their text. Keyed by float value, a
    # point written with x = -0.0 came back with the sign of whichever zero a run (or an earlier run in the
    # same process, e.g. a sweep's) had built first.
    import math

    from vcran.core.opil import build

    second = -first
    for x in (first, second):
        m = build.motion("t", "t_m1", 1, 1, x, 1.0, x, max_velocity=x, max_acceleration=x, area=[(x, 0.0), (1.0, 1.0), (0.0, 1.0)])
        signs = {math.copysign(1.0, v) for v in (m.point.x, m.point.theta, m.max_velocity.linear.x,
                                                  m.max_acceleration.linear.x, m.motion_area.polygon.points[0].x)}
        assert signs == {math.copysign(1.0, x)}
    assert build.motion("t", "t_m1", 1, 1, 2.0, 1.0).point is build.motion("u", "u_m1", 1, 1, 2.0, 1.0).point  # still shared
