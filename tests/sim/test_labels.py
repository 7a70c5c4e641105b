"""The summary's task lists (vcran.sim.labels.Labels): compact, yet exactly the labels appended, in order."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from vcran.sim.labels import Labels


def test_labels_come_back_in_order_whatever_their_length():
    # lengths on both sides of each LEB128 boundary: one length byte up to 127, two up to 16383, then three
    labels = ["", "a", "x" * 127, "y" * 128, "z" * 16383, "w" * 16384, "Förderband ü", "\ud800"]
    kept = Labels()
    for label in labels:
        kept.append(label)
    assert list(kept) == labels
    assert len(kept) == 8
    assert kept == labels and kept == tuple(labels) and kept != labels[:-1]
    # each label after how many bytes it shares with the previous one (0 here) and its length:
    # (1 + 1) + (1 + 1 + 1) + (1 + 1 + 127) + (1 + 2 + 128) + (1 + 2 + 16383) + (1 + 3 + 16384) + (1 + 1 + 14)
    # + (1 + 1 + 3) bytes ("Förderband ü" is 14 bytes of UTF-8, a lone surrogate 3)
    assert len(kept._text) == 33060


def test_a_label_keeps_only_what_differs_from_the_previous_one():
    labels = ["r7_41_1", "r7_41_2", "r7_42_1", "r7", "r7_100_1", "Förderband ü", "Förderband ä"]
    kept = Labels()
    for label in labels:
        kept.append(label)
    assert list(kept) == labels
    # (shared, rest, rest's bytes): (0, 7, 7) (6, 1, 1) (4, 3, 3) (2, 0, 0) (2, 6, 6) (0, 14, 14), and the last
    # shares 13 bytes, the first of ä's two included (ü is C3 BC, ä is C3 A4): (13, 1, 1)
    assert len(kept._text) == 9 + 3 + 5 + 2 + 8 + 16 + 3


def test_cancelled_labels_keep_their_reasons():
    kept = Labels()
    for label, reason in [("T1", "timeout"), ("T2", "cancelled"), ("T3", "timeout")]:
        kept.append(label, reason)
    assert list(kept.pairs()) == [("T1", "timeout"), ("T2", "cancelled"), ("T3", "timeout")]


@given(st.lists(st.text(max_size=300)))
def test_any_labels_round_trip(labels):
    kept = Labels()
    for label in labels:
        kept.append(label)
    assert list(kept) == labels and len(kept) == len(labels)
