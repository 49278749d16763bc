"""Scan the data section of an MCAP file whose summary cannot index it, as ``ros2 bag reindex``.

Chunk headers and the message indexes after them give the time range and counts of each chunk
without decompressing it; only chunks that declare unknown channels (or channels of unknown
schemas), or have no message index (the last chunk of a cut recording), are decompressed to
read them. Schemas and channels are read where they lie. When the footer places the end of the
data section, each record scanned must fit before it and parse; a damaged one is skipped by
resynchronising on the next run of records that do (``mcap_records``), rather than losing the
rest of the file. Damage never raises: it is noted in the file's ``DamageLog``.
"""

from __future__ import annotations

import io
import struct
from collections.abc import Iterable
from typing import BinaryIO

from mcap.data_stream import ReadDataStream
from mcap.records import Channel, Schema

from pyconnect.record.bag_damage import DamageLog
from pyconnect.record.mcap_chunks import (
    CHUNK,
    MESSAGE,
    MESSAGE_HEADER,
    RECORD_HEADER,
    ChunkBuffers,
    Span,
    chunk_problem,
    load_span,
    read_chunk_head,
)
from pyconnect.record.mcap_records import (
    CHANNEL,
    DATA_END,
    FOOTER,
    MESSAGE_INDEX,
    SCHEMA,
    RecordChecker,
)

__all__ = ["MESSAGE_INDEX_HEAD", "scan_data_section"]

MESSAGE_INDEX_HEAD = struct.Struct("<HI")  # a message index record's channel and entry bytes
_HEADS = RECORD_HEADER.size + MESSAGE_HEADER.size
_LOOSE_RUN = 4 << 20  # messages outside chunks are read in runs of about this many bytes


def scan_data_section(
    stream: BinaryIO,
    size: int,
    *,
    schemas: dict[int, Schema],
    channels: dict[int, Channel],
    times: tuple[int, int] | None,
    promised: int | None,
    damage: DamageLog,
    buffers: ChunkBuffers,
) -> list[Span]:
    """The spans of the file (chunks, runs of loose messages) with their times and counts.

    ``schemas`` and ``channels`` (those the summary declares, if any) get the ones the scan
    finds; ``times`` and ``promised`` are the statistics' log time range and message count.
    """
    scan = _Scan(stream, size, schemas=schemas, channels=channels, damage=damage, buffers=buffers)
    scan.run(times, promised)
    return scan.spans


class _Scan:
    """One scan of a data section: its state, shared by reading records and probing chunks."""

    def __init__(
        self,
        stream: BinaryIO,
        size: int,
        *,
        schemas: dict[int, Schema],
        channels: dict[int, Channel],
        damage: DamageLog,
        buffers: ChunkBuffers,
    ) -> None:
        self._stream, self._size = stream, size
        self._schemas, self._channels = schemas, channels
        self.damage, self._buffers = damage, buffers
        self.spans: list[Span] = []

    def run(self, times: tuple[int, int] | None, promised: int | None) -> None:
        """Scan the data section: chunk headers, message indexes, schemas, channels."""
        stream, size = self._stream, self._size
        records = RecordChecker(self._stream, self._size, self._channels, times)
        data_end = records.data_end()
        limit = size if data_end is None else data_end
        position = 8
        last_chunk: Span | None = None
        loose: Span | None = None
        # (offset, length, channel) of the message record before, while it is in `loose`
        previous: tuple[int, int, int] | None = None
        first_ns, last_ns = times or (0, 2**64)
        while True:
            stream.seek(position)
            head = stream.read(RECORD_HEADER.size + MESSAGE_HEADER.size)
            if len(head) < RECORD_HEADER.size:
                if head or position != size:
                    self.damage.note(position, "file ends inside a record header", key="end")
                break
            opcode, length = RECORD_HEADER.unpack_from(head)
            body = position + RECORD_HEADER.size
            end = body + length
            if opcode in (FOOTER, DATA_END) and (data_end is None or position == data_end):
                break
            message = None
            if opcode == MESSAGE and length >= MESSAGE_HEADER.size and len(head) == _HEADS:
                message = MESSAGE_HEADER.unpack_from(head, RECORD_HEADER.size)
            if data_end is None:
                fits = True
            elif message is not None:  # checked here, not by _fits: once per message counts
                fits = end <= limit and message[0] in self._channels
                fits = fits and first_ns <= message[2] <= last_ns
            else:
                fits = opcode != MESSAGE and records.fits(position, opcode, limit)
            if not fits:
                # The damage is in this record, or in the length of the message before, which
                # then led here: resynchronise from inside that one.
                start = position + 1 if previous is None else previous[0] + RECORD_HEADER.size
                resumed = records.resync(start, limit)
                if resumed is not None:
                    if previous is not None and resumed < position:
                        assert loose is not None and loose.counts is not None
                        position, length, channel = previous
                        loose.length = position - loose.offset
                        loose.counts[channel] -= 1
                        if not loose.counts[channel]:
                            del loose.counts[channel]
                        what = f"message record claims {length} bytes, where no record follows"
                    elif opcode == 0:
                        what = "no record here (zeros)"
                    elif end > limit:
                        what = f"record claims {length} bytes, more than the data section holds"
                    else:
                        what = f"broken record (type {opcode:#x}, {length} bytes)"
                    self.damage.note(
                        position,
                        f"{what}; {resumed - position} bytes skipped to the next intact record",
                    )
                    position, loose, last_chunk, previous = resumed, None, None, None
                    continue
            previous = None
            if opcode == 0:
                self.damage.note(position, "no record here (zeros); the rest is unreadable")
                break
            cut = end > limit
            if cut and opcode != CHUNK:
                self.damage.note(
                    position,
                    f"record claims {length} bytes, {limit - body} are left in the "
                    f"{'file' if limit == size else 'data section'}; the rest is lost",
                    key="end",
                )
                break
            if opcode != MESSAGE:
                loose = None
            if opcode not in (MESSAGE_INDEX, CHUNK):
                last_chunk = None
            if opcode == CHUNK:
                chunk = read_chunk_head(stream, position)
                if isinstance(chunk, str):
                    self.damage.note(position, chunk, key="end")
                    break
                problem = chunk_problem(chunk.compression, chunk.stored, chunk.uncompressed)
                if problem is not None:
                    self.damage.note(position, problem[1], key=problem[0])
                last_chunk = Span(position, chunk.start_ns, chunk.end_ns, chunked=True)
                self.spans.append(last_chunk)
                if cut:
                    break  # load_span notes how much of it is left
            elif opcode == MESSAGE_INDEX and last_chunk is not None and length >= 6:
                stream.seek(body)
                channel, entries = MESSAGE_INDEX_HEAD.unpack(stream.read(MESSAGE_INDEX_HEAD.size))
                if last_chunk.counts is None:
                    last_chunk.counts = {}
                last_chunk.counts[channel] = entries // 16
            elif opcode in (SCHEMA, CHANNEL):
                stream.seek(body)
                self._definition(opcode, stream.read(length), position)
            elif message is not None:
                channel, _, log_time, _ = message
                if loose is None or loose.length > _LOOSE_RUN:
                    loose = Span(position, log_time, log_time, chunked=False, counts={})
                    self.spans.append(loose)
                assert loose.counts is not None
                previous = (position, length, channel)
                loose.length = end - loose.offset
                loose.start_ns = min(loose.start_ns, log_time)
                loose.end_ns = max(loose.end_ns, log_time)
                loose.counts[channel] = loose.counts.get(channel, 0) + 1
            position = end
        for span in self.spans:
            if span.counts is None or not self._defined(span.counts.keys()):
                self._probe(span)
            span.channels = frozenset(span.counts or ())
        found = sum(sum((span.counts or {}).values()) for span in self.spans)
        if promised is not None and found != promised and not self.damage.found:
            # A damaged length that happens to land on a later record loses the records between
            # without a trace in the data section: only the statistics show it. (Damage already
            # noted says why messages are missing.)
            self.damage.note(
                None,
                f"the file's statistics count {promised} message(s), {found} were found in it",
            )

    def _defined(self, channel_ids: Iterable[int]) -> bool:
        """Whether those channels, and their schemas, are known (schema id 0: none needed).

        A summary that does not repeat schemas can leave them in the chunks only."""
        for channel_id in channel_ids:
            channel = self._channels.get(channel_id)
            if channel is None or (channel.schema_id and channel.schema_id not in self._schemas):
                return False
        return True

    def _definition(self, opcode: int, body: bytes, offset: int) -> None:
        try:
            stream = ReadDataStream(io.BytesIO(body))
            if opcode == SCHEMA:
                schema = Schema.read(stream)
                self._schemas.setdefault(schema.id, schema)
            else:
                channel = Channel.read(stream)
                self._channels.setdefault(channel.id, channel)
        except Exception as error:  # a damaged record: note it, keep scanning
            kind = "schema" if opcode == SCHEMA else "channel"
            self.damage.note(offset, f"{kind} record unreadable ({type(error).__name__})")

    def _probe(self, span: Span) -> None:
        """Decompress a chunk to learn its channels, counts and times."""
        records, complete = load_span(self._stream, span, self._size, self.damage, self._buffers)
        position, size = 0, len(records)
        counts: dict[int, int] = {}
        first = last = None
        while position + 9 <= size:
            opcode, length = RECORD_HEADER.unpack_from(records, position)
            body, end = position + 9, position + 9 + length
            if end > size:
                break
            if opcode in (SCHEMA, CHANNEL):
                self._definition(opcode, bytes(records[body:end]), span.offset)
            elif opcode == MESSAGE and length >= MESSAGE_HEADER.size:
                channel, _, log_time, _ = MESSAGE_HEADER.unpack_from(records, body)
                counts[channel] = counts.get(channel, 0) + 1
                first = log_time if first is None else min(first, log_time)
                last = log_time if last is None else max(last, log_time)
            position = end
        # McapFile.messages() notes broken records when it reads this chunk; here only learn
        span.counts = counts
        if first is not None and last is not None:
            span.start_ns, span.end_ns = first, last
        del complete
