"""Messages a rosbag2 bag stores compressed one by one (``compression_mode: message``),
decompressed as a storage file hands them out: the decoded read and ``raw=True`` alike."""

from __future__ import annotations

from collections.abc import Generator
from typing import TYPE_CHECKING

from pyconnect.record.bag_damage import DamageLog
from pyconnect.record.bag_storage import RawMessage

if TYPE_CHECKING:
    from zstandard import ZstdDecompressor


def decompressed(
    messages: Generator[RawMessage, None, None], compression: str, damage: DamageLog
) -> Generator[RawMessage, None, None]:
    """``messages`` of a bag whose messages are compressed one by one (``compression``, as
    ``BagFiles.message_compression``), decompressed; data that does not decompress is damage,
    noted in ``damage`` and skipped: handed out as it is, it would be taken for CDR."""
    import zstandard

    # One per read: a decompressor is not to be shared between threads.
    decompressor = zstandard.ZstdDecompressor()
    try:
        for connection_id, log_time, data in messages:
            try:
                plain = _zstd_frames(decompressor, data)
            except zstandard.ZstdError as error:
                damage.note(
                    None,
                    f"messages whose data does not decompress ({compression}: {error}) skipped",
                    key="message-decompress",
                )
                continue
            yield connection_id, log_time, plain
    finally:
        messages.close()  # now, not when collected: an MCAP read holds a chunk


def _zstd_frames(decompressor: ZstdDecompressor, data: bytes | memoryview) -> bytes:
    """The content of the zstd frames ``data`` holds (rosbag2 writes one; zstd allows more)."""
    import zstandard

    parts = []
    rest: bytes | memoryview = data
    while True:
        frame = decompressor.decompressobj()
        parts.append(frame.decompress(rest))
        if not frame.eof:
            raise zstandard.ZstdError("the data ends inside a frame")
        rest = frame.unused_data
        if not rest:
            return b"".join(parts)
