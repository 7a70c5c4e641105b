"""Fixes to the shared schema/plain modules that the codec depends on.

Each test failed before its fix: an array of Ids (RanStatus.queue) could not even be declared; a
hostile value made ``check_primitive`` raise something other than MessageError, which would leak through
the codec's "only CodecError" promise (R12); and a string with a lone surrogate (valid JSON) was
accepted, then crashed every UTF-8 writer (``vcran decode``, traces).
"""

from __future__ import annotations

import pytest

from vcran.core.opil.ids import id_for
from vcran.core.opil.messages import RanStatus, TaskEnd
from vcran.core.opil.plain import from_plain, to_plain
from vcran.core.opil.schema import MessageError, check_primitive, short_repr, specs


def _deep_list(depth: int) -> list:
    value: list = []
    for _ in range(depth):
        value = [value]
    return value


def test_array_of_ids_has_a_spec_and_a_plain_form() -> None:
    spec = {s.name: s for s in specs(RanStatus)}["queue"]
    assert (spec.kind, spec.ros) == ("array", "mars_common_msgs/Id[]")
    status = RanStatus(
        state="TASK",
        current_task_id=id_for("t1"),
        queue=(id_for("t1"), id_for("t2")),
        cancelled=(TaskEnd(id_for("t0"), "timeout"),),
    )
    plain = to_plain(status)
    assert plain["queue"][1] == {"uuid": id_for("t2").canonical, "description": "t2"}
    back = from_plain(RanStatus, plain)
    assert back == status
    assert [i.description for i in back.queue] == ["t1", "t2"]


@pytest.mark.parametrize(
    ("ros", "value", "problem"),
    [
        ("int32", 10**5000, "is outside the int32 range"),
        ("float64", 10**5000, "does not fit a float64"),
        ("float32", 10**400, "does not fit a float32"),
        ("int32", _deep_list(100_000), "expected an integer, got list"),
        ("uint8", "x" * 1_000_000, "expected an integer, got str"),
        ("string", "ok \ud800", "not valid Unicode: lone surrogate at index 3"),
    ],
    ids=["huge-int", "huge-int-float64", "huge-int-float32", "deep-list", "huge-string", "lone-surrogate"],
)
def test_check_primitive_raises_only_message_error(ros: str, value: object, problem: str) -> None:
    with pytest.raises(MessageError) as info:
        check_primitive(ros, value)
    assert problem in info.value.problem
    assert len(str(info.value)) < 200


def test_short_repr_is_bounded() -> None:
    assert short_repr(3) == "3"
    assert short_repr(True) == "True"
    assert short_repr("ab") == "'ab'"
    assert short_repr("a" * 100) == repr("a" * 40) + "..."
    assert short_repr(2**100) == "a 101-bit integer"
    assert short_repr({"a": 1}) == "dict"


def test_message_constructor_refuses_lone_surrogate_even_on_the_fast_path():
    """The constructor's fast path (schema._fast) must not skip the Unicode check (R12)."""
    import pytest

    from vcran.core.opil.messages import Tuple
    from vcran.core.opil.schema import MessageError

    with pytest.raises(MessageError, match="lone surrogate"):
        Tuple(name="a\udc80")
    assert Tuple(name="Grüße").name == "Grüße"
