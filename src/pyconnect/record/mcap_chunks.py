"""Load and scan the parts of an MCAP file that hold messages, tolerating damage.

A *span* is a chunk record, or a run of message records outside chunks. ``load_span`` returns
the span's (decompressed) records; ``scan_messages`` walks them with ``struct`` and returns the
wanted messages as zero-copy slices. Neither raises on a damaged file: a chunk cut short gives
the messages of its readable prefix, a chunk that does not decompress or whose CRC is wrong is
noted in the file's ``DamageLog`` and gives what could be read. ``chunk_problem`` says what is
wrong with a chunk's declared compression and sizes without reading it (a summary's chunk index
is checked with it when a file is opened). Compressed chunks are
decompressed straight from the file into one buffer of the declared size, so reading a chunk
holds little more than the chunk itself. Chunk buffers of a megabyte or more are anonymous memory
maps of their own, given back to the system as soon as the last message view on them goes:
from malloc, a freed multi-megabyte buffer raises glibc's mmap threshold, so the next chunks
come from the heap, whose freed pages stay counted in the process's memory (a read held ~4 MiB
more than its two chunks that way). A file reuses its last buffer for the next chunk once no
view holds it (``ChunkBuffers``). A read reads the file at positions of its own (``FileAt``), so
that reads of one file in several threads do not move each other's place.
"""

from __future__ import annotations

import io
import mmap
import os
import struct
import sys
import zlib
from dataclasses import dataclass
from typing import BinaryIO, TypeAlias, cast

from pyconnect.record.bag_damage import DamageLog
from pyconnect.record.bag_storage import RawMessage

__all__ = [
    "CHUNK",
    "MESSAGE",
    "RECORD_HEADER",
    "ChunkBuffers",
    "ChunkHead",
    "FileAt",
    "Span",
    "chunk_problem",
    "load_span",
    "read_chunk_head",
    "scan_messages",
]

CHUNK = 0x06
MESSAGE = 0x05
RECORD_HEADER = struct.Struct("<BQ")
# start time, end time, uncompressed size, uncompressed CRC, length of the compression name
_CHUNK_FIELDS = struct.Struct("<QQQII")
_U64 = struct.Struct("<Q")
# channel id, sequence, log time, publish time (the data follow)
MESSAGE_HEADER = struct.Struct("<HIQQ")
_READ_STEP = 1 << 20
_MAX_UNCOMPRESSED = 1 << 34  # a declared size beyond 16 GiB is a damaged length field
# The most a compressed byte can give: zstd's best (an RLE block, 4 bytes for 128 KiB) is
# 32768:1, lz4's 255:1 (a match length grows by 255 per byte); twice that, as a sanity bound.
_MAX_RATIO = {"zstd": 1 << 16, "lz4": 1 << 9}
_RATIO_SLACK = 1 << 12  # frame headers of a tiny chunk
_COMPRESSIONS = ("", "none", *_MAX_RATIO)
_MAPPED_FROM = 1 << 20  # buffers this big get a memory map of their own


class ChunkBuffers:
    """The chunk buffers of one file: a buffer no message view holds any more is reused.

    Fresh memory costs a page fault per page on first write (a third of loading a chunk); a
    file's chunks come one after the other, so the last chunk's buffer is usually free again when
    the next one loads. Views (message slices, numpy arrays on them) each hold a reference to the
    buffer, so a buffer referenced only here is free; one still viewed is left to its views.
    """

    __slots__ = ("_spare",)

    def __init__(self) -> None:
        self._spare: mmap.mmap | bytearray | None = None

    def take(self, size: int) -> memoryview:
        """A writable buffer of ``size`` bytes, freed to the system when its last view goes."""
        spare = self._spare
        # References: self._spare, `spare` and getrefcount's argument; any view adds one.
        if spare is not None and len(spare) >= size and sys.getrefcount(spare) == 3:
            return memoryview(spare)[:size]
        self._spare = None
        del spare
        buffer = mmap.mmap(-1, size) if size >= _MAPPED_FROM else bytearray(size)
        self._spare = buffer
        return memoryview(buffer)


class FileAt:
    """An open file read at a position of its own, with ``os.pread``: seek-then-read on a file
    object shared by reads in two threads reads at whichever position the other left."""

    __slots__ = ("_fd", "_position")

    def __init__(self, fd: int) -> None:
        self._fd = fd
        self._position = 0

    def seek(self, position: int) -> int:
        self._position = position
        return position

    def tell(self) -> int:
        return self._position

    def read(self, size: int = -1) -> bytes:
        if size < 0:
            size = max(0, os.fstat(self._fd).st_size - self._position)
        data = os.pread(self._fd, size, self._position)
        self._position += len(data)
        return data

    def readinto(self, buffer: memoryview) -> int:
        got = os.preadv(self._fd, [buffer], self._position)
        self._position += got
        return got


# What chunks are read from: the file object (when it is opened), or a read's own place in it.
Source: TypeAlias = BinaryIO | FileAt


@dataclass
class Span:
    """Where messages are: a chunk (``chunked``) or ``length`` bytes of loose records."""

    offset: int
    start_ns: int
    end_ns: int
    chunked: bool
    length: int = 0
    counts: dict[int, int] | None = None  # messages per channel id; None: not known yet
    channels: frozenset[int] | None = None  # channels with messages here; None: not known


@dataclass(frozen=True)
class ChunkHead:
    """The fields of a chunk record before its records, which start at ``records_at``."""

    start_ns: int
    end_ns: int
    uncompressed: int  # the declared size of its records once decompressed
    crc: int
    compression: str
    stored: int  # the size of its (compressed) records in the file
    records_at: int


def read_chunk_head(stream: Source, offset: int) -> ChunkHead | str:
    """The head of the chunk record at ``offset``, or what is wrong there."""
    stream.seek(offset)
    head = stream.read(RECORD_HEADER.size + _CHUNK_FIELDS.size)
    if len(head) < RECORD_HEADER.size + _CHUNK_FIELDS.size:
        return "file ends inside a chunk header"
    opcode, _ = RECORD_HEADER.unpack_from(head)
    if opcode != CHUNK:
        return f"no chunk where the index points (record type {opcode:#x})"
    start_ns, end_ns, size, crc, name_length = _CHUNK_FIELDS.unpack_from(head, RECORD_HEADER.size)
    name = stream.read(name_length) if name_length <= 16 else b"?"
    length_field = stream.read(8)
    if len(name) != name_length or len(length_field) != 8:
        return "file ends inside a chunk header"
    (stored,) = _U64.unpack(length_field)
    compression = name.decode("ascii", "replace")
    return ChunkHead(start_ns, end_ns, size, crc, compression, stored, stream.tell())


def _largest_output(compression: str, stored: int) -> int:
    """The most ``stored`` bytes of ``compression`` can decompress to."""
    ratio = _MAX_RATIO.get(compression)
    largest = stored if ratio is None else stored * ratio + _RATIO_SLACK
    return min(largest, _MAX_UNCOMPRESSED)


def chunk_problem(compression: str, stored: int, uncompressed: int) -> tuple[str, str] | None:
    """What is wrong with a chunk's declared compression and sizes, as (key, text) for a
    ``DamageLog`` note; None when nothing is. Says the same when its chunk is opened and read,
    so that the note is made once."""
    if compression not in _COMPRESSIONS:
        return "compression", f"unsupported chunk compression {compression!r}; skipped"
    if compression in ("", "none"):
        if stored != uncompressed:
            return "size", f"uncompressed chunk of {stored} bytes, its header says {uncompressed}"
        return None
    if uncompressed > _largest_output(compression, stored):
        return "size", (
            f"chunk claims {uncompressed} bytes uncompressed, more than its {stored} bytes of "
            f"{compression} can hold; read as far as it decompresses"
        )
    return None


class _Window:
    """``read(n)`` of at most ``remaining`` bytes of a stream: a chunk's compressed records."""

    def __init__(self, stream: Source, remaining: int) -> None:
        self._stream = stream
        self._remaining = remaining

    def read(self, size: int = -1) -> bytes:
        if size < 0 or size > self._remaining:
            size = self._remaining
        data = self._stream.read(size)
        self._remaining -= len(data)
        return data


def _decompress_zstd(
    source: _Window, view: memoryview, damage: DamageLog, offset: int
) -> memoryview:
    import zstandard

    size = len(view)
    filled = 0
    try:
        with zstandard.ZstdDecompressor().stream_reader(
            source,  # type: ignore[arg-type]  # any object with read(n) will do
            read_size=_READ_STEP,
            closefd=False,
        ) as reader:
            while filled < size:
                got = reader.readinto(view[filled:])
                if not got:
                    break
                filled += got
    except zstandard.ZstdError as error:
        damage.note(offset, f"chunk does not decompress (zstd: {error})", key="decompress")
    return view[:filled]


def _decompress_lz4(source: _Window, out: memoryview, damage: DamageLog, offset: int) -> memoryview:
    import lz4.frame

    size = len(out)
    filled = 0
    decompressor = lz4.frame.LZ4FrameDecompressor()
    try:
        while filled < size:
            piece = source.read(_READ_STEP)
            if not piece:
                break
            produced = decompressor.decompress(piece)
            take = min(len(produced), size - filled)
            out[filled : filled + take] = produced[:take]
            filled += take
            if decompressor.eof:
                break
    except RuntimeError as error:
        damage.note(offset, f"chunk does not decompress (lz4: {error})", key="decompress")
    return out[:filled]


def _decompress_unsized(
    source: _Window, compression: str, largest: int, damage: DamageLog, offset: int
) -> memoryview:
    """Up to ``largest`` bytes of records whose declared size is damaged, in a buffer grown as
    they decompress: a buffer of the largest size they could have may be more than memory."""
    import lz4.frame
    import zstandard

    out = bytearray()
    try:
        if compression == "zstd":
            with zstandard.ZstdDecompressor().stream_reader(
                source,  # type: ignore[arg-type]  # any object with read(n) will do
                read_size=_READ_STEP,
                closefd=False,
            ) as reader:
                while len(out) < largest and (piece := reader.read(_READ_STEP)):
                    out += piece
        else:
            decompressor = lz4.frame.LZ4FrameDecompressor()
            while (
                len(out) < largest and not decompressor.eof and (piece := source.read(_READ_STEP))
            ):
                out += decompressor.decompress(piece)
    except (zstandard.ZstdError, RuntimeError) as error:
        what = f"chunk does not decompress ({compression}: {error})"
        damage.note(offset, what, key="decompress")
    return memoryview(out)[:largest]


def _read_into_buffer(stream: Source, buffer: memoryview) -> memoryview:
    """Up to ``len(buffer)`` bytes of ``stream`` (fewer at its end), read straight into it."""
    size = len(buffer)
    # A file object is opened "rb": a BufferedReader, which BinaryIO does not say has readinto.
    reader = stream if isinstance(stream, FileAt) else cast("io.BufferedIOBase", stream)
    filled = 0
    while filled < size:
        got = reader.readinto(buffer[filled:])
        if not got:
            break
        filled += got
    return buffer[:filled]


def load_span(
    stream: Source, span: Span, file_size: int, damage: DamageLog, buffers: ChunkBuffers
) -> tuple[memoryview, bool]:
    """The records of ``span`` and whether they are complete (False: cut short or damaged)."""
    if not span.chunked:
        stream.seek(span.offset)
        loose = _read_into_buffer(stream, buffers.take(span.length))
        return loose, len(loose) == span.length
    offset = span.offset
    head = read_chunk_head(stream, offset)
    if isinstance(head, str):
        damage.note(offset, head, key="header")
        return memoryview(b""), False
    compression, stored, size = head.compression, head.stored, head.uncompressed
    available = max(0, min(stored, file_size - head.records_at))
    complete = available == stored
    if not complete:
        damage.note(
            offset,
            f"chunk cut short: {available} of its {stored} bytes are in the file",
            key="cut",
        )
    problem = chunk_problem(compression, stored, size)
    if problem is not None:
        key, what = problem
        damage.note(offset, what, key=key)
        if key == "compression":
            return memoryview(b""), False
        if compression not in ("", "none"):
            # The declared size is damaged, maybe not the records: decompress what they give.
            largest = _largest_output(compression, stored)
            records = _decompress_unsized(
                _Window(stream, available), compression, largest, damage, offset
            )
            return records.toreadonly(), False
    if compression in ("", "none"):
        records = _read_into_buffer(stream, buffers.take(available))
    elif compression == "zstd":
        records = _decompress_zstd(_Window(stream, available), buffers.take(size), damage, offset)
    else:
        records = _decompress_lz4(_Window(stream, available), buffers.take(size), damage, offset)
    if complete and len(records) != size:
        damage.note(
            offset,
            f"chunk holds {len(records)} bytes, its header says {size}",
            key="size",
        )
        complete = False
    if complete and head.crc and zlib.crc32(records) != head.crc:
        damage.note(
            offset,
            "chunk CRC mismatch: its messages are delivered but may be altered",
            key="crc",
        )
    return records.toreadonly(), complete


def scan_messages(
    records: memoryview,
    wanted: set[int] | None,
    start_ns: int,
    end_ns: int,
    *,
    complete: bool,
    damage: DamageLog,
    offset: int,
) -> list[RawMessage]:
    """The wanted messages of a span's records, in the order stored (``wanted`` None: all).

    A record that runs past the end is damage when the records were complete, and the expected
    end of a chunk cut short otherwise; scanning stops there either way.
    """
    unpack_record = RECORD_HEADER.unpack_from
    unpack_message = MESSAGE_HEADER.unpack_from
    found: list[RawMessage] = []
    position, size = 0, len(records)
    while position + 9 <= size:
        opcode, length = unpack_record(records, position)
        body = position + 9
        end = body + length
        if end > size or (opcode == MESSAGE and length < MESSAGE_HEADER.size):
            if complete:
                damage.note(
                    offset,
                    f"broken record {position} bytes into the chunk; the rest of it is lost",
                    key="record",
                )
            break
        position = end
        if opcode != MESSAGE:
            continue
        channel, _, log_time, _ = unpack_message(records, body)
        if (wanted is not None and channel not in wanted) or not start_ns <= log_time < end_ns:
            continue
        found.append((channel, log_time, records[body + MESSAGE_HEADER.size : end]))
    else:
        if complete and position != size:
            damage.note(offset, "chunk ends inside a record header", key="record")
    return found
