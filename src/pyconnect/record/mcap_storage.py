"""Read MCAP files: through the summary's chunk index, or by scanning a file that has none.

A complete file is read through its summary (schemas, channels, statistics, chunk index). A
file without a usable summary — a recording cut short, a damaged index — is scanned once when
opened, as ``ros2 bag reindex`` would (``mcap_scan``). Either way, messages are then read chunk
by chunk in log-time order (``messages``), holding at most two chunks at a time. Damage never
raises: it is noted in ``damage`` and the intact messages are delivered (see ``mcap_chunks``).

A file scanned although its summary is readable (one written without chunks has no chunk index;
one whose summary does not repeat its channels and schemas, as the spec allows, has them in its
chunks only) keeps the summary's statistics as the counts it promises, and the schemas and
channels it declares.
"""

from __future__ import annotations

import bisect
import heapq
import os
from collections.abc import Generator, Iterator, Sequence
from operator import itemgetter
from pathlib import Path
from typing import BinaryIO

from mcap.reader import make_reader
from mcap.records import Channel, Schema
from mcap.summary import Summary

from pyconnect.record.bag_damage import DamageLog
from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_storage import Connection, RawMessage
from pyconnect.record.mcap_chunks import (
    CHUNK,
    RECORD_HEADER,
    ChunkBuffers,
    FileAt,
    Span,
    chunk_problem,
    load_span,
    scan_messages,
)
from pyconnect.record.mcap_records import MAGIC
from pyconnect.record.mcap_scan import MESSAGE_INDEX_HEAD, scan_data_section
from pyconnect.record.message_compression import readable

__all__ = ["McapFile"]

_DEFINITION_ENCODINGS = ("ros2msg", "ros2idl")


_log_time = itemgetter(1)  # of a RawMessage; in C, as sort and merge call it per message
_span_offset = itemgetter(0)  # of a (span offset, messages) pair


def _release(
    held: list[tuple[int, list[RawMessage]]], found: list[RawMessage], before: int | None
) -> list[RawMessage]:
    """The messages of ``held`` (span offset, its messages in log-time order) earlier than
    ``before`` (None: all) in log-time order, equal times in the spans' file order; ``held``
    keeps the others, those of ``found`` (the span just read) copied so that its chunk can go.

    A function of its own so that none of its names outlives it holding a view on that chunk,
    whose buffer then could not be reused for the next (``ChunkBuffers``).
    """
    parts: list[list[RawMessage]] = []
    waiting: list[tuple[int, list[RawMessage]]] = []
    for offset, messages in held:
        cut = (
            len(messages) if before is None else bisect.bisect_left(messages, before, key=_log_time)
        )
        if cut == len(messages):
            parts.append(messages)
            continue
        if cut:
            parts.append(messages[:cut])
        rest = messages[cut:] if cut else messages
        if messages is found:  # those of spans read before are copies already
            rest = [(c, t, bytes(d)) for c, t, d in rest]
        waiting.append((offset, rest))
    held[:] = waiting
    if len(parts) == 1:
        return parts[0]
    # heapq.merge gives equal keys in the order of its inputs: the spans' file order.
    return list(heapq.merge(*parts, key=_log_time))


def _declares_its_channels(summary: Summary) -> bool:
    """Whether the summary declares every channel (and its schema) its chunk indexes and
    statistics name: a file whose summary does not repeat them has them in its chunks only."""
    named = {channel for index in summary.chunk_indexes for channel in index.message_index_offsets}
    if summary.statistics is not None:
        named.update(c for c, n in summary.statistics.channel_message_counts.items() if n)
    if not summary.channels or not named <= summary.channels.keys():
        return False
    # Schema id 0: a channel without schema, which needs none.
    return all(
        channel.schema_id == 0 or channel.schema_id in summary.schemas
        for channel in summary.channels.values()
    )


class McapFile:
    """One ``.mcap`` file of a bag (or a bare MCAP file); ``damage`` lists what is broken."""

    def __init__(self, path: Path, *, message_compression: str = "") -> None:
        self.path = str(path)
        self.damage = DamageLog(self.path)
        self._message_compression = message_compression  # BagFiles.message_compression
        self._stream: BinaryIO = path.open("rb")
        self._size = os.fstat(self._stream.fileno()).st_size
        if self._stream.read(8) != MAGIC:
            self._stream.close()
            raise BagError(f"{path}: not an MCAP file")
        self._schemas: dict[int, Schema] = {}
        self._channels: dict[int, Channel] = {}
        self._spans: list[Span] = []
        self._buffers = ChunkBuffers()
        self._counts: dict[int, int] | None = None
        self.promised: int | None = None
        """How many messages the file's statistics declare (None: it has none)."""
        self._times: tuple[int, int] | None = None  # the statistics' first and last log time
        summary = self._usable_summary()
        if summary is not None:
            self._spans = [
                Span(
                    offset=c.chunk_start_offset,
                    start_ns=c.message_start_time,
                    end_ns=c.message_end_time,
                    chunked=True,
                    channels=frozenset(c.message_index_offsets) or None,
                )
                for c in summary.chunk_indexes
            ]
            if self._counts is None:
                self._count_from_message_indexes(summary)
        else:
            self._spans = scan_data_section(
                self._stream,
                self._size,
                schemas=self._schemas,
                channels=self._channels,
                times=self._times,
                promised=self.promised,
                damage=self.damage,
                buffers=self._buffers,
            )
        self._spans.sort(key=lambda s: (s.start_ns, s.offset))
        self._connections = self._make_connections()

    # -- opening --------------------------------------------------------------------------
    def _usable_summary(self) -> Summary | None:
        """The summary when it indexes every message, else None (the file is then scanned)."""
        self._stream.seek(max(0, self._size - 8))
        ends_well = self._size >= 16 and self._stream.read(8) == MAGIC
        if not ends_well:
            self.damage.note(
                self._size,
                "the file is cut short (no summary, no index, no end magic); "
                "its messages were recovered by scanning it",
            )
            return None
        try:
            self._stream.seek(0)
            summary = make_reader(self._stream).get_summary()
        except Exception as error:  # any failure of a damaged summary: scan instead
            self.damage.note(None, f"summary unreadable ({type(error).__name__}: {error})")
            return None
        if summary is None:
            return None
        # Scanned or not, the file keeps what its summary declares: the statistics are what it
        # promises, and its schemas and channels are defined before a damaged record can hide
        # them.
        self._schemas, self._channels = dict(summary.schemas), dict(summary.channels)
        statistics = summary.statistics
        if statistics is not None:
            self.promised = statistics.message_count
            self._counts = dict(statistics.channel_message_counts)
            self._times = (statistics.message_start_time, statistics.message_end_time)
        if not summary.chunk_indexes:
            empty = statistics is not None and statistics.message_count == 0
            return summary if empty else None
        if not _declares_its_channels(summary):
            # Allowed by the spec (a writer need not repeat its channels and schemas in the
            # summary): read through it, their messages would be taken for no topic's.
            return None
        for index in summary.chunk_indexes:
            where = index.chunk_start_offset
            if where + index.chunk_length > self._size or where < 8:
                self.damage.note(
                    where,
                    f"the chunk index points past the end of the file ({self._size} bytes); "
                    "the file was scanned instead",
                )
                return None
            self._stream.seek(where)
            if self._stream.read(1) != bytes([CHUNK]):
                self.damage.note(
                    where, "the chunk index points where there is no chunk; scanned instead"
                )
                return None
        for index in summary.chunk_indexes:
            # Found now, not when the chunk is read, so that `bag info` reports it too.
            problem = chunk_problem(
                index.compression, index.compressed_size, index.uncompressed_size
            )
            if problem is not None:
                key, what = problem
                self.damage.note(index.chunk_start_offset, what, key=key)
        return summary

    def _count_from_message_indexes(self, summary: Summary) -> None:
        """Counts per chunk from its message index records, for a summary without statistics."""
        for span, index in zip(self._spans, summary.chunk_indexes, strict=True):
            span.counts = {}
            for channel, offset in index.message_index_offsets.items():
                self._stream.seek(offset + RECORD_HEADER.size)
                head = self._stream.read(MESSAGE_INDEX_HEAD.size)
                if len(head) == MESSAGE_INDEX_HEAD.size:
                    span.counts[channel] = MESSAGE_INDEX_HEAD.unpack(head)[1] // 16

    def _make_connections(self) -> list[Connection]:
        connections = []
        for channel in self._channels.values():
            schema = self._schemas.get(channel.schema_id)
            definition = None
            encoding = "ros2msg"
            msg_type = ""
            if schema is not None:
                msg_type = schema.name
                if schema.encoding in _DEFINITION_ENCODINGS:
                    definition = schema.data.decode("utf-8", "replace")
                    encoding = schema.encoding
            type_hash = channel.metadata.get("topic_type_hash", "")
            connections.append(
                Connection(
                    id=channel.id,
                    topic=channel.topic,
                    msg_type=msg_type,
                    serialization_format=channel.message_encoding,
                    definition=definition,
                    definition_encoding=encoding,
                    offered_qos_profiles=channel.metadata.get("offered_qos_profiles", ""),
                    type_hash=type_hash,
                )
            )
        return connections

    # -- the StorageFile protocol ---------------------------------------------------------
    def connections(self) -> Sequence[Connection]:
        return self._connections

    def message_counts(self) -> dict[int, int]:
        counts = {connection.id: 0 for connection in self._connections}
        if self._counts is not None:
            counts.update(self._counts)
            return counts
        for span in self._spans:
            for channel, count in (span.counts or {}).items():
                counts[channel] = counts.get(channel, 0) + count
        return counts

    def time_range(self) -> tuple[int, int] | None:
        spans = [s for s in self._spans if s.counts is None or any(s.counts.values())]
        if not spans:
            return None
        return min(s.start_ns for s in spans), max(s.end_ns for s in spans)

    def messages(
        self, connection_ids: set[int], start_ns: int | None, end_ns: int | None
    ) -> Iterator[RawMessage]:
        stored = self._stored_messages(connection_ids, start_ns, end_ns)
        return readable(stored, self._message_compression, self.damage)

    def _stored_messages(
        self, connection_ids: set[int], start_ns: int | None, end_ns: int | None
    ) -> Generator[RawMessage, None, None]:
        """Chunk by chunk in start-time order; a message is held back only while a later
        chunk may still hold an earlier one, and then copied so that its chunk can go."""
        if not connection_ids:
            return
        start = -1 if start_ns is None else start_ns
        end = 2**64 if end_ns is None else end_ns
        spans = [
            s
            for s in self._spans
            if s.end_ns >= start
            and s.start_ns < end
            and (s.channels is None or not s.channels.isdisjoint(connection_ids))
        ]
        # Per span, its messages held back, the spans in file order: messages of equal log
        # times then come in the order they were written, as rosbag2 gives them, although the
        # spans are read in start-time order.
        held: list[tuple[int, list[RawMessage]]] = []
        source = FileAt(self._stream.fileno())  # its own place in the file: see FileAt
        for number, span in enumerate(spans):
            records, complete = load_span(source, span, self._size, self.damage, self._buffers)
            found = scan_messages(
                records,
                connection_ids,
                start,
                end,
                complete=complete,
                damage=self.damage,
                offset=span.offset,
            )
            del records
            found.sort(key=_log_time)  # stable: equal log times stay in record order
            if found:
                bisect.insort(held, (span.offset, found), key=_span_offset)
            more = number + 1 < len(spans)
            ready = _release(held, found, spans[number + 1].start_ns if more else None)
            del found
            if ready and more:
                # The caller still holds the last message (and its value, a view on it) when it
                # asks for the next, which loads the next chunk: a copy of that one message lets
                # this chunk go first, so a read holds one chunk and a message, not two chunks.
                channel, log_time, view = ready[-1]
                ready[-1] = (channel, log_time, bytes(view))
                del view
            yield from ready
            del ready

    def close(self) -> None:
        self._stream.close()
