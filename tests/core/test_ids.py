"""Ids where they are built (docs/contract.md §2: a `mars_common_msgs/Id` is sixteen bytes; R12: uuid arrays not of
16 bytes are bad input). The decoder refuses a wrong-length uuid array before an Id exists; these tests
pin the same refusal on the Id itself, for ids a program builds without the wire."""

from __future__ import annotations

import dataclasses

import pytest

from vcran.core.opil.ids import Id, IdError, NamedId, id_for


@pytest.mark.parametrize("size", [15, 0, 17])
def test_r12_an_id_of_other_than_16_bytes_is_refused_where_it_is_built(size):
    with pytest.raises(ValueError, match=f"^uuid must have 16 bytes, got {size}$") as refused:
        Id(bytes(size), "short")
    assert isinstance(refused.value, IdError)


@pytest.mark.parametrize("build", [
    lambda: dataclasses.replace(id_for("A"), uuid=bytes(15)),  # a copy with other bytes is built again
    lambda: NamedId(bytes(15), "A"),  # the class id_for returns, called directly
])
def test_r12_a_15_byte_id_is_refused_however_the_constructor_is_reached(build):
    with pytest.raises(IdError, match="^uuid must have 16 bytes, got 15$"):
        build()
