"""Messages a rosbag2 bag stores compressed one by one (``compression_mode: message``),
decompressed as a storage file hands them out: the decoded read and ``raw=True`` alike.

Only metadata.yaml says a bag compresses its messages. A storage file read without it (a bare
``.mcap``, a folder before ``ros2 bag reindex``) is read with ``MAYBE_ZSTD``: a message whose
data begins with a zstd frame's magic number is decompressed, any other is taken as it is. CDR
begins with its encapsulation kind, whose first byte is 0, so neither is taken for the other.
"""

from __future__ import annotations

from collections.abc import Generator, Iterator
from typing import TYPE_CHECKING

from pyconnect.record.bag_damage import DamageLog
from pyconnect.record.bag_storage import RawMessage

if TYPE_CHECKING:
    from zstandard import ZstdDecompressor


MAX_MESSAGE_BYTES = 1 << 30
"""The most one message may decompress to: a few kB of zstd can claim or expand to gigabytes
(a 128 kB frame to 4 GB), and no ROS message in a bag is near 1 GiB."""

MAYBE_ZSTD = "zstd?"
"""The compression of a storage file whose bag says nothing: zstd where a message's data is a
zstd frame (``readable``)."""

ZSTD_MAGIC = b"\x28\xb5\x2f\xfd"
"""The first four bytes of a zstd frame."""

_INPUT_STEP = 1 << 12  # compressed bytes fed at a time: each gives at most ~128 MiB of output


class _TooLarge(ValueError):
    """A message that decompresses to more than ``MAX_MESSAGE_BYTES``."""


def readable(
    stored: Generator[RawMessage, None, None], compression: str, damage: DamageLog
) -> Iterator[RawMessage]:
    """A storage file's ``stored`` messages as CDR: as they are, or ``decompressed`` when the
    bag compressed them one by one (``compression``: "" when it did not, ``MAYBE_ZSTD`` when
    the bag does not say)."""
    return decompressed(stored, compression, damage) if compression else stored


def decompressed(
    messages: Generator[RawMessage, None, None], compression: str, damage: DamageLog
) -> Generator[RawMessage, None, None]:
    """``messages`` of a bag whose messages are compressed one by one (``compression``, as
    ``BagFiles.message_compression``), decompressed; data that does not decompress, or to more
    than ``MAX_MESSAGE_BYTES``, is damage, noted in ``damage`` and skipped: handed out as it
    is, it would be taken for CDR. Under ``MAYBE_ZSTD`` only data that starts as a zstd frame
    is decompressed."""
    import zstandard

    # One per read: a decompressor is not to be shared between threads.
    decompressor = zstandard.ZstdDecompressor()
    sniffing = compression == MAYBE_ZSTD
    if sniffing:
        compression = "zstd"
    try:
        for connection_id, log_time, data in messages:
            if sniffing and data[:4] != ZSTD_MAGIC:
                yield connection_id, log_time, data
                continue
            try:
                plain = _zstd_frames(decompressor, data)
            except zstandard.ZstdError as error:
                damage.note(
                    None,
                    f"messages whose data does not decompress ({compression}: {error}) skipped",
                    key="message-decompress",
                )
                continue
            except (_TooLarge, MemoryError):
                damage.note(
                    None,
                    f"messages that decompress ({compression}) to more than "
                    f"{MAX_MESSAGE_BYTES} bytes skipped",
                    key="message-too-large",
                )
                continue
            yield connection_id, log_time, plain
    finally:
        messages.close()  # now, not when collected: an MCAP read holds a chunk


def _zstd_frames(decompressor: ZstdDecompressor, data: bytes | memoryview) -> bytes:
    """The content of the zstd frames ``data`` holds (rosbag2 writes one; zstd allows more),
    refused (``_TooLarge``) as soon as it would pass ``MAX_MESSAGE_BYTES``: a frame's declared
    size is checked before anything is decompressed, one without it is fed a little at a time."""
    import zstandard

    parts = []
    total = 0
    rest = memoryview(data)
    while True:
        if zstandard.frame_content_size(rest) > MAX_MESSAGE_BYTES:  # -1: not declared
            raise _TooLarge
        frame = decompressor.decompressobj()
        offset = 0
        while not frame.eof and offset < len(rest):
            piece = frame.decompress(rest[offset : offset + _INPUT_STEP])
            offset += _INPUT_STEP
            total += len(piece)
            if total > MAX_MESSAGE_BYTES:
                raise _TooLarge
            parts.append(piece)
        if not frame.eof:
            raise zstandard.ZstdError("the data ends inside a frame")
        # What the last piece held beyond the frame, then what was not fed yet: more frames.
        rest = memoryview(frame.unused_data + bytes(rest[offset:]))
        if not rest:
            return b"".join(parts)
