"""The summary's task lists, compact: :class:`Labels` (summary.json's ``completed`` and ``cancelled``, docs/contract.md §8).

A run ends tens of thousands of tasks per robot-hour at fleet scale, and every one is listed in summary.json;
kept as Python strings they were most of what a run's memory grew by. Shared by every protocol: a protocol's
glue appends the label of each task (OPIL) or order (VDA 5050) that ended.
"""

from __future__ import annotations

from array import array
from collections.abc import Iterator


def _put_size(buf: bytearray, size: int) -> None:
    """Append ``size`` in LEB128: seven bits a byte, low bits first, the high bit saying "more follows"."""
    while size >= 0x80:
        buf.append(0x80 | size & 0x7F)
        size >>= 7
    buf.append(size)


def _get_size(buf: bytearray, i: int) -> tuple[int, int]:
    """The LEB128 number at ``buf[i]`` and the position after it."""
    size = shift = 0
    while True:
        byte = buf[i]
        i += 1
        size |= (byte & 0x7F) << shift
        if byte < 0x80:
            return size, i
        shift += 7


class Labels:
    """Task labels in order, for the summary, front-coded in one buffer, optionally with a second short
    text each (a cancel's reason).

    A run ends tens of thousands of tasks per robot-hour at fleet scale, and every one is listed in
    summary.json. A list of strings (and of dicts) was most of what a run's memory grew by; an offset
    per label still cost 8 bytes beside a label of about 10. A robot's task ids mostly differ from the
    previous one in their last characters (``r7_41_2`` after ``r7_41_1``), so each label is kept as how
    many UTF-8 bytes it shares with the previous one, then the rest (both lengths in LEB128: one byte
    each below 128): about 3 bytes a task. The labels are only ever read in order.
    """

    __slots__ = ("_text", "_last", "_count", "_tags", "_tag_names")

    def __init__(self) -> None:
        self._text = bytearray()
        self._last = b""
        self._count = 0
        self._tags = array("B")
        self._tag_names: list[str] = []

    def append(self, label: str, tag: str | None = None) -> None:
        data = label.encode("utf-8", "surrogatepass")
        last = self._last
        shared, most = 0, min(len(data), len(last))
        while shared < most and data[shared] == last[shared]:
            shared += 1
        _put_size(self._text, shared)
        _put_size(self._text, len(data) - shared)
        self._text += data[shared:]
        self._last = data
        self._count += 1
        if tag is not None:
            if tag not in self._tag_names:
                self._tag_names.append(tag)
            self._tags.append(self._tag_names.index(tag))

    def __len__(self) -> int:
        return self._count

    def __iter__(self) -> Iterator[str]:
        text, i, end, last = self._text, 0, len(self._text), b""
        while i < end:
            shared, i = _get_size(text, i)
            rest, i = _get_size(text, i)
            last = last[:shared] + text[i:i + rest]
            i += rest
            yield last.decode("utf-8", "surrogatepass")

    def __eq__(self, other: object) -> bool:
        """Equal to a list of the same labels (what callers compared before it was compact)."""
        if isinstance(other, (list, tuple, Labels)):
            return list(self) == list(other)
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]

    def pairs(self) -> Iterator[tuple[str, str]]:
        return zip(self, (self._tag_names[i] for i in self._tags))
