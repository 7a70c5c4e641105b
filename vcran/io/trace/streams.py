"""The compressed streams a run's files are (docs/outputs.md): written in batches, read as they are
decompressed, and checked whole, since a zstd stream cut off reads as a shorter one without an error."""

from __future__ import annotations

import io
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

#: zstd level 3 (zstd's default: 300+ MB/s). Long-distance matching does not pay here: measured on a
#: 1000-robot hour's trace it saved 1.5% for twice the compression time and a 128 MiB window per file.
ZSTD_LEVEL = 3
ZSTD_WINDOW_LOG = 23  # 8 MiB: what a run's repeats need (27 with long-distance matching: 1.5% smaller, 2x the CPU, 128 MiB)

def open_output(path: Path) -> _Batched:
    """A file that compresses what is written to it when its name ends in ``.zst``; lines written to it are
    gathered in batches either way (:class:`_Batched`)."""
    raw = path.open("wb")
    if path.suffix != ".zst":
        return _Batched(raw)
    import zstandard

    params = zstandard.ZstdCompressionParameters.from_level(
        ZSTD_LEVEL, window_log=ZSTD_WINDOW_LOG, write_checksum=True)
    return _Batched(zstandard.ZstdCompressor(compression_params=params).stream_writer(raw, write_size=1 << 20))


#: Bytes gathered before they cross into the compressor.
BATCH = 1 << 18


class _Batched(io.RawIOBase):
    """Lines gathered into batches of 256 kB before they cross into the compressor: a call into
    zstandard per record cost more than compressing it.

    The batch is an ``io.BytesIO`` rewound after each hand-on: its buffer grows to a batch's size once
    and is then refilled in place, lines copied into it by C code. A buffer emptied after each batch
    was reallocated (and, among a large run's other allocations, copied) dozens of times a batch, 5% of
    a 1000-robot run (py-spy); a list of the lines joined per batch raised the run's peak memory by
    14 MiB (the allocator kept what thousands of line objects a batch had used), and lines joined 64 at a
    time by 3 MiB at 4 h; a ``bytearray`` filled by slice assignment cost 0.5 µs a line, an eighth of
    what writing a 10-robot run's outputs costs (issue 14). A line longer than a batch (a raw payload
    near Orion's 1 MB limit) makes one batch that long; the buffer it grew is released after it.

    The batch stays the same object for the file's life, so that the run's writers, which write a line per
    record, add to it themselves (``batch.write``, then :meth:`hand_on` once it holds :data:`BATCH`
    bytes) rather than through :meth:`write`, a Python call per line (issue 30). zstd's output does not
    depend on where its input was cut into calls, only on :meth:`flush`."""

    def __init__(self, inner: Any) -> None:
        super().__init__()
        self._inner, self.batch = inner, io.BytesIO()

    def writable(self) -> bool:
        return True

    def write(self, data: Any) -> int:
        batch = self.batch
        batch.write(data)
        if batch.tell() >= BATCH:
            self.hand_on()
        return len(data)

    def hand_on(self) -> None:
        """Pass what the batch holds on to the compressor (or the file), and start the batch again."""
        batch = self.batch
        size = batch.tell()
        if size:
            with batch.getbuffer() as view:
                self._inner.write(view[:size])
            batch.seek(0)
            if size > 2 * BATCH:  # grown by a long line: its buffer is not kept for the batches after it
                batch.truncate(0)

    def flush(self) -> None:
        """Compress what is gathered and end the zstd block: a reader of the file gets every line so far."""
        if not self.closed and self._inner is not None:
            self.hand_on()
            self._inner.flush()

    def close(self) -> None:
        if not self.closed:
            self.hand_on()
            self._inner.close()
            self._inner = None
        super().close()


ZSTD_MAGIC = b"\x28\xb5\x2f\xfd"


def zst_cut_off(path: Path) -> bool:
    """Whether the zstd file ``path`` ends before its last frame does (a ValueError if it is no zstd
    stream at all). A truncated stream reads as a shorter one, without an error: cut at a block boundary
    it even ends with a whole line. Walks the block headers (a seek per 128 kB block), decompressing nothing."""
    import zstandard

    size = path.stat().st_size
    pos = 0
    with path.open("rb") as f:
        while pos < size:
            f.seek(pos)
            head = f.read(18)  # a frame header is at most 18 bytes
            if len(head) >= 4 and head[0] & 0xF0 == 0x50 and head[1:4] == b"\x2a\x4d\x18":  # a skippable frame
                pos += 8 + int.from_bytes(head[4:8], "little")  # (pzstd writes them): its length, then its bytes
                if len(head) < 8:
                    return True
                continue
            if head[:4] != ZSTD_MAGIC[: len(head)]:
                raise ValueError(f"{path}: not a zstd stream")
            try:
                pos += zstandard.frame_header_size(head)
                checksum = zstandard.get_frame_parameters(head).has_checksum
            except zstandard.ZstdError:  # the magic number, and the file ends inside the header
                return True
            last = False
            while not last:
                f.seek(pos)
                block = f.read(3)
                if len(block) < 3:
                    return True
                bits = int.from_bytes(block, "little")
                last, kind = bool(bits & 1), (bits >> 1) & 3
                pos += 3 + (1 if kind == 1 else bits >> 3)  # an RLE block holds one byte
            pos += 4 if checksum else 0
    return pos > size or size == 0


def check_whole(path: Path) -> None:
    """A ValueError when the zstd file ``path`` of a finished run is cut off (:func:`zst_cut_off`): read
    as it is, it would pass for a shorter run. A plain (format 1) file is taken as it is."""
    if path.suffix == ".zst" and zst_cut_off(path):
        raise ValueError(f"{path}: cut off: the zstd stream ends before its end (the file was truncated or its "
                         "run killed)")


def open_input(path: Path) -> IO[bytes]:
    """Read ``path``, decompressing a ``.zst`` file as it is read."""
    if path.suffix != ".zst":
        return path.open("rb")
    import zstandard

    reader = zstandard.ZstdDecompressor(max_window_size=1 << 27).stream_reader(path.open("rb"), closefd=True)
    return io.BufferedReader(reader, buffer_size=1 << 20)  # type: ignore[arg-type]


def whole_lines(f: IO[bytes]) -> Iterator[bytes]:
    """The complete lines of ``f``: up to a cut-off last line or a truncated zstd stream."""
    try:
        for line in f:
            if not line.endswith(b"\n"):
                return
            yield line
    except Exception as exc:  # zstandard.ZstdError: the stream ends mid-block
        if type(exc).__name__ != "ZstdError":
            raise
