"""Checking MCAP records where they lie in a file: does the one at an offset parse and fit?

A file scanned record by record (``mcap_scan``, when its summary cannot index it) must not
trust a damaged length: it would skip intact records, or read past the data section. When the
footer places the end of the data section (``data_end``), each record must end before it and
parse as its kind's layout says (``fits``); after one that does not, ``resync`` finds the next
run of records that do.
"""

from __future__ import annotations

import re
import struct
from collections.abc import Collection, Mapping
from typing import BinaryIO

from pyconnect.record.mcap_chunks import CHUNK, MESSAGE, MESSAGE_HEADER, RECORD_HEADER

__all__ = [
    "CHANNEL",
    "DATA_END",
    "FOOTER",
    "MAGIC",
    "MESSAGE_INDEX",
    "SCHEMA",
    "RecordChecker",
]

MAGIC = b"\x89MCAP0\r\n"
FOOTER, SCHEMA, CHANNEL, MESSAGE_INDEX, DATA_END = 0x02, 0x03, 0x04, 0x07, 0x0F
HEADER, ATTACHMENT, METADATA = 0x01, 0x09, 0x0C
_FOOTER_SIZE = RECORD_HEADER.size + 20  # summary start, summary offset start, CRC
_DATA_END_SIZE = RECORD_HEADER.size + 4  # CRC
_U32, _U64 = struct.Struct("<I"), struct.Struct("<Q")
# How the body of each record a data section may hold is laid out: a positive number is a field
# of that many bytes, a negative one a length of -n bytes followed by that many bytes. A body
# must be exactly what its layout adds up to. (A message is checked apart: its data have no
# length of their own.)
_LAYOUTS: dict[int, tuple[int, ...]] = {
    SCHEMA: (2, -4, -4, -4),  # id, name, encoding, data
    CHANNEL: (4, -4, -4, -4),  # id and schema id, topic, message encoding, metadata
    CHUNK: (28, -4, -8),  # times, size, CRC; compression; records
    MESSAGE_INDEX: (2, -4),  # channel id, entries
    ATTACHMENT: (16, -4, -4, -8, 4),  # times, name, media type, data, CRC
    METADATA: (-4, -4),  # name, entries
}
_FIRST_UNKNOWN = 0x10  # opcodes from here on are reserved or private: skipped where found
_RESYNC_RUN = 3  # records in a row that must parse for a resync (or reach the data's end)
_RESYNC_STEP = 1 << 20  # bytes searched at a time for the next record


class RecordChecker:
    """Checks the records of one open MCAP file of ``size`` bytes. ``channels`` (the file's,
    filled as the scan defines them) and ``times`` (its statistics' first and last log time,
    None when it has none) say which messages are plausible."""

    def __init__(
        self,
        stream: BinaryIO,
        size: int,
        channels: Mapping[int, object],
        times: tuple[int, int] | None,
    ) -> None:
        self._stream = stream
        self._size = size
        self._channels = channels
        self._times = times

    def data_end(self) -> int | None:
        """Where the data section ends (its DataEnd record) as the footer places it; None when
        the file does not end with a footer."""
        stream, footer_at = self._stream, self._size - len(MAGIC) - _FOOTER_SIZE
        if footer_at < len(MAGIC):
            return None
        stream.seek(footer_at)
        footer = stream.read(_FOOTER_SIZE + len(MAGIC))
        if footer[_FOOTER_SIZE:] != MAGIC or RECORD_HEADER.unpack_from(footer) != (
            FOOTER,
            _FOOTER_SIZE - RECORD_HEADER.size,
        ):
            return None
        (summary_start,) = _U64.unpack_from(footer, RECORD_HEADER.size)
        end = (summary_start or footer_at) - _DATA_END_SIZE
        if not len(MAGIC) <= end <= footer_at - _DATA_END_SIZE:
            return None
        stream.seek(end)
        data_end = stream.read(RECORD_HEADER.size)
        if RECORD_HEADER.unpack(data_end) != (DATA_END, _DATA_END_SIZE - RECORD_HEADER.size):
            return None
        return end

    def resync(self, start: int, limit: int) -> int | None:
        """The first offset from ``start`` where ``_RESYNC_RUN`` records in a row (or all up to
        ``limit``, the data section's end) parse and fit: the next intact record after a
        damaged one. None when there is none."""
        # A record's length must fit before `limit`: its top bytes are zero, which a search by
        # regular expression finds fast, leaving few candidates to check one by one.
        zeros = 8 - (limit.bit_length() + 7) // 8
        opcodes = re.escape(bytes(sorted((*_LAYOUTS, MESSAGE))))
        candidate = re.compile(
            b"(?=[%b].{%d}%b)" % (opcodes, 8 - zeros, b"\\x00" * zeros), re.DOTALL
        )
        stream = self._stream
        block = start
        while block < limit:
            stream.seek(block)
            data = stream.read(min(_RESYNC_STEP, limit - block) + RECORD_HEADER.size - 1)
            for found in candidate.finditer(data):
                position = block + found.start()
                if position >= limit:
                    return None
                if self._record_run(position, limit):
                    return position
            block += _RESYNC_STEP
        return None

    def _record_run(self, position: int, limit: int) -> bool:
        """Whether ``_RESYNC_RUN`` plausible records in a row (or all up to ``limit``) start at
        ``position``."""
        channels = set(self._channels)  # and those the run defines, for its messages
        for _ in range(_RESYNC_RUN):
            found = self._plausible_record(position, limit, channels)
            if found is None:
                return False
            end, defined = found
            if defined is not None:
                channels.add(defined)
            if end == limit:
                return True
            position = end
        return True

    def fits(self, position: int, opcode: int, limit: int) -> bool:
        """Whether the record at ``position`` fits before ``limit`` and, of a kind a data section
        holds, parses. A record of another kind is skipped, as the MCAP format has it, when it
        leads to one that parses (a damaged length seldom does)."""
        for _ in range(_RESYNC_RUN):
            known = opcode == MESSAGE or opcode in _LAYOUTS
            header = opcode == HEADER and position == len(MAGIC)
            if opcode < _FIRST_UNKNOWN and not known and not header:
                return False  # zeros, or a record that belongs elsewhere (header, summary)
            if known:
                return self._plausible_record(position, limit, self._channels) is not None
            self._stream.seek(position)
            head = self._stream.read(RECORD_HEADER.size)
            if len(head) < RECORD_HEADER.size:
                return False
            opcode, length = RECORD_HEADER.unpack(head)
            position += RECORD_HEADER.size + length
            if position >= limit:
                return bool(position == limit)
            self._stream.seek(position)
            opcode = self._stream.read(1)[0]
        return True

    def _message_fits(self, head: bytes, channels: Collection[int]) -> bool:
        """Whether a message record, whose header and message header are ``head``, is of one of
        ``channels`` and in the time range of the file's statistics."""
        if len(head) < RECORD_HEADER.size + MESSAGE_HEADER.size:
            return False
        _, length = RECORD_HEADER.unpack_from(head)
        if length < MESSAGE_HEADER.size:
            return False
        channel, _, log_time, _ = MESSAGE_HEADER.unpack_from(head, RECORD_HEADER.size)
        times = self._times
        return channel in channels and (times is None or times[0] <= log_time <= times[1])

    def _plausible_record(
        self, position: int, limit: int, channels: Collection[int]
    ) -> tuple[int, int | None] | None:
        """The end of the record at ``position`` if it parses and fits before ``limit`` (a
        message must be of one of ``channels``), and the id a channel record defines."""
        stream = self._stream
        stream.seek(position)
        head = stream.read(RECORD_HEADER.size + MESSAGE_HEADER.size)
        if len(head) < RECORD_HEADER.size:
            return None
        opcode, length = RECORD_HEADER.unpack_from(head)
        body = position + RECORD_HEADER.size
        end: int = body + length
        if end > limit:
            return None
        if opcode == MESSAGE:
            return (end, None) if self._message_fits(head, channels) else None
        layout = _LAYOUTS.get(opcode)
        if layout is None:
            return None
        at = body
        for field in layout:
            if field < 0:
                stream.seek(at)
                size = stream.read(-field)
                if len(size) != -field:
                    return None
                (field_length,) = (_U32 if field == -4 else _U64).unpack(size)
                at += -field + field_length
            else:
                at += field
            if at > end:
                return None
        if at != end:
            return None
        if opcode == CHANNEL:
            return end, int.from_bytes(head[RECORD_HEADER.size : RECORD_HEADER.size + 2], "little")
        return end, None
