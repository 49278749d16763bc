"""Damaged MCAP files: unchunked files resynchronised past a broken record, chunk damage that
opening the file shows (so that ``bag info`` reports it)."""

from __future__ import annotations

import io
import random
import struct
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer
from rclpy.serialization import serialize_message
from std_msgs.msg import String

from pyconnect.cli import main
from pyconnect.record.bag_reader import bag_info, open_bag
from pyconnect.record.mcap_recorder import McapRecorder

COUNT = 20
MESSAGE_OPCODE = 0x05


def write_unchunked(path: Path, count: int = COUNT) -> list[tuple[int, bytes]]:
    """An MCAP file of ``count`` /chatter messages outside chunks (rosbag2's noChunking), with
    its summary; returns (log time, CDR) of each message as written."""
    written = []
    with path.open("wb") as stream:
        writer = Writer(stream, compression=CompressionType.NONE, use_chunking=False)
        writer.start(profile="ros2", library="test")
        schema = writer.register_schema("std_msgs/msg/String", "ros2msg", b"string data")
        channel = writer.register_channel("/chatter", "cdr", schema)
        for i in range(count):
            data = bytes(serialize_message(String(data=f"message {i:03d}" + "x" * (i % 7))))
            writer.add_message(channel, 1_000 + i, data, 1_000 + i, i)
            written.append((1_000 + i, data))
        writer.finish()
    return written


def message_records(data: bytes) -> list[tuple[int, int]]:
    """(offset, end) of each message record of an intact unchunked file, in file order."""
    found = []
    position = 8
    while True:
        opcode, length = struct.unpack_from("<BQ", data, position)
        end = position + 9 + length
        if opcode == MESSAGE_OPCODE:
            found.append((position, end))
        if opcode == 0x0F:  # DataEnd
            return found
        position = end


def read_all(path: Path) -> tuple[list[tuple[int, bytes]], list[str], str]:
    with open_bag(path, raw=True) as bag:
        messages = [(m.log_time_ns, bytes(m.value)) for m in bag]
        damage = bag.damage
        return messages, [str(d) for d in damage], bag.damage_summary(damage) if damage else ""


def test_unchunked_broken_record_loses_only_that_message(tmp_path: Path) -> None:
    path = tmp_path / "unchunked.mcap"
    written = write_unchunked(path)
    data = bytearray(path.read_bytes())
    broken, next_record = message_records(bytes(data))[2]
    struct.pack_into("<Q", data, broken + 1, 2**40)
    path.write_bytes(data)

    messages, damage, summary = read_all(path)
    assert messages == written[:2] + written[3:]
    assert damage == [
        f"{path} at byte {broken}: record claims {2**40} bytes, more than the data section holds; "
        f"{next_record - broken} bytes skipped to the next intact record"
    ]
    assert summary.endswith(f"{COUNT - 1} message(s) read, the bag's metadata promised {COUNT}")
    info = bag_info(path)
    assert info.message_count == COUNT  # what the statistics promise
    assert [str(d) for d in info.damage] == damage


def test_unchunked_zeroed_record_is_skipped(tmp_path: Path) -> None:
    path = tmp_path / "unchunked.mcap"
    written = write_unchunked(path)
    data = bytearray(path.read_bytes())
    start, end = message_records(bytes(data))[5]
    data[start:end] = bytes(end - start)
    path.write_bytes(data)

    messages, damage, _ = read_all(path)
    assert messages == written[:5] + written[6:]
    assert len(damage) == 1
    assert "no record here (zeros)" in damage[0]


def test_unchunked_last_record_broken(tmp_path: Path) -> None:
    """Nothing intact after the broken record: the rest is lost, nothing invented."""
    path = tmp_path / "unchunked.mcap"
    written = write_unchunked(path)
    data = bytearray(path.read_bytes())
    broken, _ = message_records(bytes(data))[-1]
    struct.pack_into("<Q", data, broken + 1, 2**33)
    path.write_bytes(data)

    messages, damage, summary = read_all(path)
    assert messages == written[:-1]
    assert len(damage) == 1
    assert "the rest is lost" in damage[0]
    assert summary.endswith(f"{COUNT - 1} message(s) read, the bag's metadata promised {COUNT}")


def test_unchunked_length_that_fits_but_is_wrong(tmp_path: Path) -> None:
    """A low bit flipped in a message's length: it ends inside a later record, which does not
    parse; the scan resynchronises from inside that message and drops it (its length is wrong,
    so is what it would deliver), nothing else."""
    path = tmp_path / "unchunked.mcap"
    written = write_unchunked(path)
    data = bytearray(path.read_bytes())
    flipped, _ = message_records(bytes(data))[4]
    data[flipped + 2] ^= 0x01  # the length's second byte: 256 bytes more
    path.write_bytes(data)

    messages, damage, _ = read_all(path)
    assert messages == written[:4] + written[5:]
    assert len(damage) == 1
    assert damage[0].startswith(f"{path} at byte {flipped}: message record claims ")


def test_unchunked_length_landing_on_a_record_is_told_by_the_statistics(tmp_path: Path) -> None:
    """A length that happens to end where a later record starts swallows the records between
    without a trace in the data section; the statistics still tell that messages are missing."""
    path = tmp_path / "unchunked.mcap"
    written = write_unchunked(path)
    data = bytearray(path.read_bytes())
    records = message_records(bytes(data))
    struct.pack_into("<Q", data, records[2][0] + 1, records[6][0] - records[2][0] - 9)
    path.write_bytes(data)

    messages, damage, summary = read_all(path)
    assert messages[:2] + messages[3:] == written[:2] + written[6:]
    assert damage == [
        f"{path}: the file's statistics count {COUNT} message(s), 17 were found in it"
    ]
    assert summary.endswith(f"17 message(s) read, the bag's metadata promised {COUNT}")


def test_unchunked_garbage_delivers_every_intact_message(tmp_path: Path) -> None:
    """Random bytes over random stretches: every record they do not touch is delivered, and no
    message is made up of the garbage."""
    original = tmp_path / "unchunked.mcap"
    written = write_unchunked(original, count=200)
    clean = original.read_bytes()
    records = message_records(clean)
    rng = random.Random(20261124)
    for trial in range(40):
        data = bytearray(clean)
        start = rng.randrange(records[0][0], records[-1][1] - 64)
        stop = start + rng.randrange(1, 300)
        data[start:stop] = rng.randbytes(stop - start)
        damaged = tmp_path / f"garbage_{trial}.mcap"
        damaged.write_bytes(data)
        messages, _, _ = read_all(damaged)
        intact = [
            message
            for message, (begin, end) in zip(written, records, strict=True)
            if end <= start or begin >= stop
        ]
        touched = [
            message
            for message, (begin, end) in zip(written, records, strict=True)
            if not (end <= start or begin >= stop)
        ]
        assert set(intact) <= set(messages), f"trial {trial}: {start}..{stop}"
        made_up = [m for m in messages if m not in written]
        # A message whose record only the garbage touched may come back altered (nothing checks
        # the data of a message outside a chunk), but never more of them than were touched.
        assert len(made_up) + len(intact) <= len(messages) <= len(written)
        assert len(made_up) <= len(touched), f"trial {trial}: {made_up}"


def test_unchunked_without_damage_reads_as_before(tmp_path: Path) -> None:
    path = tmp_path / "unchunked.mcap"
    written = write_unchunked(path)
    messages, damage, _ = read_all(path)
    assert messages == written
    assert damage == []
    assert bag_info(path).message_count == COUNT


# -- chunk damage found when opening ---------------------------------------------------------
def write_chunked(path: Path, compression: str = "zstd") -> Path:
    with McapRecorder(path, compression=compression) as recorder:
        recorder.add_topic("/chatter", "std_msgs/msg/String")
        for i in range(COUNT):
            data = bytes(serialize_message(String(data=f"message {i:05d}")))
            recorder.write("/chatter", data, log_time_ns=1_000 + i)
    return path


def chunk_size_fields(data: bytes) -> tuple[int, int]:
    """Offsets of the uncompressed size field of the only chunk and of its chunk index."""
    summary = make_reader(io.BytesIO(data)).get_summary()
    assert summary is not None
    (index,) = summary.chunk_indexes
    in_chunk = index.chunk_start_offset + 9 + 16  # after the opcode, length, start and end
    name = struct.pack("<I", len(index.compression)) + index.compression.encode()
    sizes = struct.pack("<QQ", index.compressed_size, index.uncompressed_size)
    in_index = data.index(name + sizes, index.chunk_start_offset + index.chunk_length)
    return in_chunk, in_index + len(name) + 8


@pytest.mark.parametrize("compression", ["zstd", "lz4"])
def test_impossible_uncompressed_size_is_damage_at_open(
    compression: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = write_chunked(tmp_path / "bag.mcap", compression)
    with open_bag(path, raw=True) as bag:
        written = [(m.log_time_ns, bytes(m.value)) for m in bag]
    data = bytearray(path.read_bytes())
    for field in chunk_size_fields(bytes(data)):
        struct.pack_into("<Q", data, field, 2**40)
    path.write_bytes(data)

    info = bag_info(path)
    assert info.message_count == COUNT
    assert len(info.damage) == 1
    assert f"chunk claims {2**40} bytes uncompressed" in info.damage[0].what
    assert main(["bag", "info", str(path)]) == 1
    assert "damaged bag" in capsys.readouterr().err
    # Only the size field is damaged: the records still decompress, all of them are read.
    messages, damage, _ = read_all(path)
    assert messages == written
    assert [str(d) for d in info.damage] == damage


def test_unsupported_compression_is_damage_at_open(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = write_chunked(tmp_path / "bag.mcap")
    data = path.read_bytes()
    assert data.count(b"\x04\x00\x00\x00zstd") == 2  # the chunk and its index
    path.write_bytes(data.replace(b"\x04\x00\x00\x00zstd", b"\x04\x00\x00\x00zsXd"))

    info = bag_info(path)
    assert [d.what for d in info.damage] == ["unsupported chunk compression 'zsXd'; skipped"]
    assert main(["bag", "info", str(path)]) == 1
    assert "unsupported chunk compression 'zsXd'" in capsys.readouterr().err
    messages, damage, summary = read_all(path)
    assert messages == []
    assert damage == [str(d) for d in info.damage]  # noted once, at open
    assert summary.endswith(f"0 message(s) read, the bag's metadata promised {COUNT}")


def test_bag_info_reads_no_chunk(tmp_path: Path) -> None:
    """A CRC mismatch shows only when the chunk is read: `bag info` reads the summary, not
    every chunk of the bag (which would cost as much as reading it all)."""
    path = write_chunked(tmp_path / "bag.mcap")
    data = bytearray(path.read_bytes())
    in_chunk, _ = chunk_size_fields(bytes(data))
    data[in_chunk + 8] ^= 0xFF  # the CRC follows the uncompressed size
    path.write_bytes(data)

    assert bag_info(path).damage == ()
    messages, damage, _ = read_all(path)
    assert len(messages) == COUNT
    assert damage == [
        f"{path} at byte {in_chunk - 25}: chunk CRC mismatch: its messages are delivered but "
        "may be altered"
    ]
