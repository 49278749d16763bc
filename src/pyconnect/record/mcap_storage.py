"""Read MCAP files: the summary through the ``mcap`` package, messages by scanning whole chunks.

The ``mcap`` reader builds one Python object per record; scanning a decompressed chunk with
``struct`` instead is several times faster, and message data stay zero-copy ``memoryview`` slices
of the chunk (so wire codecs can return numpy views into it). Files without a summary or chunk
index (a recording cut short) fall back to the ``mcap`` package's streaming reader.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import BinaryIO

from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Channel, Chunk, ChunkIndex, McapRecord, Message, Schema
from mcap.stream_reader import StreamReader
from mcap.summary import Summary

from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_storage import Connection, RawMessage

__all__ = ["McapFile"]

_MESSAGE = 0x05
_CHUNK = 0x06
_RECORD_HEADER = struct.Struct("<BQ")
# channel id, sequence, log time, publish time (the data follow)
_MESSAGE_HEADER = struct.Struct("<HIQQ")
_DEFINITION_ENCODINGS = ("ros2msg", "ros2idl")


def _decompress(chunk: Chunk, path: str) -> bytes:
    if chunk.compression in ("", "none"):
        return chunk.data
    if chunk.compression == "zstd":
        import zstandard

        data: bytes = zstandard.ZstdDecompressor().decompress(
            chunk.data, max_output_size=chunk.uncompressed_size
        )
        return data
    if chunk.compression == "lz4":
        import lz4.frame

        decompressed: bytes = lz4.frame.decompress(chunk.data)
        return decompressed
    raise BagError(f"{path}: unsupported MCAP chunk compression {chunk.compression!r}")


def _scan_chunk(data: bytes, wanted: set[int], start_ns: int, end_ns: int) -> list[RawMessage]:
    """The wanted messages of a decompressed chunk, in the order stored."""
    view = memoryview(data)
    unpack_record = _RECORD_HEADER.unpack_from
    unpack_message = _MESSAGE_HEADER.unpack_from
    found: list[RawMessage] = []
    position, size = 0, len(data)
    while position < size:
        opcode, length = unpack_record(data, position)
        body = position + 9
        position = body + length
        if opcode != _MESSAGE:
            continue
        channel, _, log_time, _ = unpack_message(data, body)
        if channel not in wanted or log_time < start_ns or log_time >= end_ns:
            continue
        found.append((channel, log_time, view[body + 22 : position]))
    return found


class McapFile:
    """One ``.mcap`` file of a bag (or a bare MCAP file)."""

    def __init__(self, path: Path) -> None:
        self.path = str(path)
        self._stream: BinaryIO = path.open("rb")
        try:
            self._summary: Summary | None = make_reader(self._stream).get_summary()
        except (McapError, ValueError, struct.error, EOFError) as error:
            self._summary = None
            self._stream.seek(0)
            if self._stream.read(8) != b"\x89MCAP0\r\n":
                self._stream.close()
                raise BagError(f"{path}: not an MCAP file ({error})") from None
        self._indexed = self._summary is not None and (
            bool(self._summary.chunk_indexes)
            or (
                self._summary.statistics is not None and self._summary.statistics.message_count == 0
            )
        )
        self._connections = self._read_connections()

    def _read_connections(self) -> list[Connection]:
        if self._summary is not None:
            schemas, channels = self._summary.schemas, self._summary.channels
        else:
            schemas, channels = {}, {}
            for record in self._unindexed_records():
                if isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel):
                    channels[record.id] = record
        connections = []
        for channel in channels.values():
            schema = schemas.get(channel.schema_id)
            definition = None
            encoding = "ros2msg"
            msg_type = ""
            if schema is not None:
                msg_type = schema.name
                if schema.encoding in _DEFINITION_ENCODINGS:
                    definition = schema.data.decode("utf-8")
                    encoding = schema.encoding
            connections.append(
                Connection(
                    id=channel.id,
                    topic=channel.topic,
                    msg_type=msg_type,
                    serialization_format=channel.message_encoding,
                    definition=definition,
                    definition_encoding=encoding,
                    offered_qos_profiles=channel.metadata.get("offered_qos_profiles", ""),
                )
            )
        return connections

    def _unindexed_records(self) -> Iterator[McapRecord]:
        """Every record up to the end, or up to where a recording cut short stops making sense."""
        self._stream.seek(0)
        try:
            yield from StreamReader(self._stream, skip_magic=False).records
        except (McapError, EOFError, struct.error, ValueError):
            return  # keep what was readable, as `ros2 bag reindex` does

    def connections(self) -> Sequence[Connection]:
        return self._connections

    def message_counts(self) -> dict[int, int]:
        counts = {connection.id: 0 for connection in self._connections}
        summary = self._summary
        if summary is not None and summary.statistics is not None and self._indexed:
            for channel_id, count in summary.statistics.channel_message_counts.items():
                counts[channel_id] = count
            return counts
        for channel_id, _, _ in self.messages(set(counts), None, None):
            counts[channel_id] += 1
        return counts

    def time_range(self) -> tuple[int, int] | None:
        summary = self._summary
        if summary is not None and self._indexed:
            statistics = summary.statistics
            if statistics is not None:
                if statistics.message_count == 0:
                    return None
                return statistics.message_start_time, statistics.message_end_time
            if summary.chunk_indexes:
                return (
                    min(c.message_start_time for c in summary.chunk_indexes),
                    max(c.message_end_time for c in summary.chunk_indexes),
                )
        first = last = None
        for _, log_time, _ in self.messages({c.id for c in self._connections}, None, None):
            first = log_time if first is None else min(first, log_time)
            last = log_time if last is None else max(last, log_time)
        return None if first is None or last is None else (first, last)

    def messages(
        self, connection_ids: set[int], start_ns: int | None, end_ns: int | None
    ) -> Iterator[RawMessage]:
        if not connection_ids:
            return
        start = -1 if start_ns is None else start_ns
        end = 2**64 if end_ns is None else end_ns
        summary = self._summary
        if summary is None or not self._indexed:
            yield from self._streamed_messages(connection_ids, start, end)
            return
        chunks = sorted(
            (
                c
                for c in summary.chunk_indexes
                if c.message_end_time >= start
                and c.message_start_time < end
                and (not c.message_index_offsets or connection_ids & c.message_index_offsets.keys())
            ),
            key=lambda c: (c.message_start_time, c.chunk_start_offset),
        )
        # Chunks whose time ranges overlap are merged and sorted together (sorting the usual
        # single, already ordered chunk is linear in timsort).
        pending: list[RawMessage] = []
        pending_end = -1
        for chunk_index in chunks:
            found = _scan_chunk(self._read_chunk(chunk_index), connection_ids, start, end)
            if pending and chunk_index.message_start_time < pending_end:
                pending.extend(found)
                pending_end = max(pending_end, chunk_index.message_end_time)
                continue
            if pending:
                pending.sort(key=_log_time)
                yield from pending
            pending, pending_end = found, chunk_index.message_end_time
        if pending:
            pending.sort(key=_log_time)
            yield from pending

    def _read_chunk(self, index: ChunkIndex) -> bytes:
        self._stream.seek(index.chunk_start_offset)
        opcode, _ = _RECORD_HEADER.unpack(self._stream.read(9))
        if opcode != _CHUNK:
            raise BagError(f"{self.path}: no chunk at offset {index.chunk_start_offset}")
        return _decompress(Chunk.read(ReadDataStream(self._stream)), self.path)

    def _streamed_messages(self, wanted: set[int], start: int, end: int) -> Iterator[RawMessage]:
        found: list[RawMessage] = []
        for record in self._unindexed_records():
            if not isinstance(record, Message):
                continue
            if record.channel_id in wanted and start <= record.log_time < end:
                found.append((record.channel_id, record.log_time, record.data))
        yield from sorted(found, key=_log_time)

    def close(self) -> None:
        self._stream.close()


def _log_time(message: RawMessage) -> int:
    return message[1]
