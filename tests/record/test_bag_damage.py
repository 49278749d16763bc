"""Damaged bags: every intact message delivered, the damage reported once, nothing raised."""

from __future__ import annotations

import logging
import random
import struct
import tempfile
from pathlib import Path

import pytest
from mcap.reader import make_reader
from rclpy.serialization import serialize_message
from std_msgs.msg import String

from pyconnect.cli import main
from pyconnect.record.bag_reader import bag_info, open_bag
from pyconnect.record.mcap_recorder import McapRecorder
from tests.conftest import require_sample_bags
from tests.record.bag_samples import BAGS

SHARED_MCAP = BAGS / "robot_localization_converted/test1_ros2_mcap_zstd"
SHARED_DB3 = BAGS / "evo/tf_example/tf_example.db3"


def write_chunked(path: Path, *, count: int = 600, compression: str = "zstd") -> Path:
    """A bag of small chunks (so that a cut or a flip loses one chunk, not all)."""
    with McapRecorder(path, compression=compression, chunk_size=2048) as recorder:
        recorder.add_topic("/chatter", "std_msgs/msg/String")
        for i in range(count):
            data = bytes(serialize_message(String(data=f"message {i:05d}")))
            recorder.write("/chatter", data, log_time_ns=1_000 + i)
    return path


def read_raw(path: Path) -> tuple[list[tuple[str, int, bytes]], list[str]]:
    with open_bag(path, raw=True) as bag:
        messages = [(m.topic, m.log_time_ns, m.value) for m in bag]
        return messages, [str(d) for d in bag.damage]


def chunk_spans(path: Path) -> list[tuple[int, int, int]]:
    """(start offset, end offset, message count) of each chunk of an intact file."""
    with path.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    times = [t for _, t, _ in read_raw(path)[0]]
    return [
        (
            index.chunk_start_offset,
            index.chunk_start_offset + index.chunk_length,
            sum(index.message_start_time <= t <= index.message_end_time for t in times),
        )
        for index in summary.chunk_indexes
    ]


def damage_warnings(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.getMessage() for r in caplog.records if "damaged bag" in r.getMessage()]


@pytest.mark.parametrize("source", ["written", "shared"])
def test_cut_at_random_offsets(
    source: str, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    if source == "written":
        original = write_chunked(tmp_path / "bag.mcap")
    else:
        require_sample_bags(SHARED_MCAP, SHARED_MCAP.exists())
        original = next(SHARED_MCAP.glob("*.mcap"))
    data = original.read_bytes()
    full, damage = read_raw(original)
    assert damage == []
    index = {message: n for n, message in enumerate(sorted(full, key=lambda m: m[1]))}
    ends = chunk_spans(original)
    rng = random.Random(20261123)
    offsets = sorted(rng.sample(range(9, len(data) - 1), 100 if source == "written" else 12))
    for cut in offsets:
        damaged = tmp_path / f"cut_{cut}.mcap"
        damaged.write_bytes(data[:cut])
        caplog.clear()
        with caplog.at_level(logging.WARNING, logger="pyconnect.record"):
            got, damage = read_raw(damaged)
        # Nothing altered, nothing twice, and at least every message of the whole chunks.
        assert len(set(got)) == len(got), cut
        assert set(got) <= index.keys(), cut
        whole = sum(count for _, end, count in ends if end <= cut)
        assert len(got) >= whole, cut
        assert damage and "cut short" in damage[0], cut
        warnings = damage_warnings(caplog)
        assert len(warnings) == 1, cut
        assert f"{len(got)} message(s) read" in warnings[0]
        damaged.unlink()


def test_cut_recording_reports_what_the_metadata_promised(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    bag = tmp_path / "bag"
    with McapRecorder(bag, chunk_size=2048) as recorder:
        recorder.add_topic("/chatter", "std_msgs/msg/String")
        for i in range(300):
            data = bytes(serialize_message(String(data=f"message {i:05d}")))
            recorder.write("/chatter", data, log_time_ns=1_000 + i)
    file = bag / "bag_0.mcap"
    file.write_bytes(file.read_bytes()[:5000])
    with caplog.at_level(logging.WARNING, logger="pyconnect.record"), open_bag(bag) as reader:
        count = sum(1 for _ in reader)
    assert 0 < count < 300
    assert damage_warnings(caplog) == [
        f"{bag}: damaged bag: {file} at byte 5000: the file is cut short (no summary, no index, "
        "no end magic); its messages were recovered by scanning it (and 1 more problem(s)); "
        f"{count} message(s) read, the bag's metadata promised 300"
    ]


def test_header_only_file_is_damaged_not_empty(tmp_path: Path) -> None:
    original = write_chunked(tmp_path / "bag.mcap", count=5)
    head = tmp_path / "head.mcap"
    head.write_bytes(original.read_bytes()[:40])
    messages, damage = read_raw(head)
    assert messages == []
    assert damage[0] == (
        f"{head} at byte 40: the file is cut short (no summary, no index, no end magic); "
        "its messages were recovered by scanning it"
    )
    assert bag_info(head).damage


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_flipped_bytes_in_chunk_bodies(compression: str, tmp_path: Path) -> None:
    original = write_chunked(tmp_path / "bag.mcap", compression=compression)
    full, _ = read_raw(original)
    spans = chunk_spans(original)
    rng = random.Random(7)
    data = bytearray(original.read_bytes())
    hit = spans[len(spans) // 2]
    for _ in range(8):  # inside the chunk's records, past its header
        data[rng.randrange(hit[0] + 80, hit[1])] ^= 0xFF
    damaged = tmp_path / "flipped.mcap"
    damaged.write_bytes(bytes(data))
    got, damage = read_raw(damaged)
    assert damage, "damage not reported"
    with original.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    index = next(i for i in summary.chunk_indexes if i.chunk_start_offset == hit[0])
    outside = {m for m in full if not index.message_start_time <= m[1] <= index.message_end_time}
    assert outside <= set(got)  # every message of the intact chunks, unchanged
    assert len(got) == len(set(got))


def test_wrong_crc_is_reported_and_messages_delivered(tmp_path: Path) -> None:
    original = write_chunked(tmp_path / "bag.mcap", compression="none")
    full, _ = read_raw(original)
    start = chunk_spans(original)[0][0]
    data = bytearray(original.read_bytes())
    crc_at = start + 9 + 8 + 8 + 8  # opcode+length, start, end, uncompressed size
    struct.pack_into("<I", data, crc_at, struct.unpack_from("<I", data, crc_at)[0] ^ 1)
    damaged = tmp_path / "crc.mcap"
    damaged.write_bytes(bytes(data))
    got, damage = read_raw(damaged)
    assert got == full
    assert damage == [
        f"{damaged} at byte {start}: chunk CRC mismatch: its messages are delivered but may be "
        "altered"
    ]


def test_index_pointing_past_the_end(tmp_path: Path) -> None:
    original = write_chunked(tmp_path / "bag.mcap")
    full, _ = read_raw(original)
    with original.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    last = summary.chunk_indexes[-1].chunk_start_offset
    data = bytearray(original.read_bytes())
    # The chunk index record stores the chunk's offset right after its two times.
    needle = struct.pack(
        "<QQQ",
        summary.chunk_indexes[-1].message_start_time,
        summary.chunk_indexes[-1].message_end_time,
        last,
    )
    where = bytes(data).rindex(needle)
    struct.pack_into("<Q", data, where + 16, len(data) + 1_000_000)
    damaged = tmp_path / "index.mcap"
    damaged.write_bytes(bytes(data))
    got, damage = read_raw(damaged)
    assert got == full
    assert damage == [
        f"{damaged} at byte {len(data) + 1_000_000}: the chunk index points past the end of the "
        f"file ({len(data)} bytes); the file was scanned instead"
    ]


@pytest.mark.parametrize("fraction", [0.3, 0.5, 0.7, 0.9, 0.99])
def test_db3_cut_short(fraction: float, tmp_path: Path) -> None:
    require_sample_bags(SHARED_DB3, SHARED_DB3.exists())
    full, _ = read_raw(SHARED_DB3)
    data = SHARED_DB3.read_bytes()
    cut = int(len(data) * fraction)
    damaged = tmp_path / "cut.db3"
    damaged.write_bytes(data[:cut])
    got, damage = read_raw(damaged)
    assert set(got) <= set(full)
    assert len(set(got)) == len(got)
    assert damage[0] == (
        f"{damaged} at byte {cut}: the file is cut short: {cut} of the {len(data)} bytes its "
        "header declares"
    )
    if fraction >= 0.7:
        assert len(got) > len(full) // 2
    assert list(tmp_path.iterdir()) == [damaged]
    assert not list(Path(tempfile.gettempdir()).glob("pyconnect-salvage-*"))  # copy removed


@pytest.mark.parametrize(
    ("cut", "told"),
    [
        (3000, "3000 of the 106496 bytes its header declares"),
        (50, "50 of the 100 bytes of a sqlite3 header"),
    ],
)
def test_db3_cut_inside_its_first_page_is_a_damaged_bag(
    cut: int, told: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Page 1 holds the schema: cut inside it, no table can be found. That is a damaged bag with
    # nothing left to read (exit 1), not "not a sqlite3 bag" (exit 2, a usage error).
    require_sample_bags(SHARED_DB3, SHARED_DB3.exists())
    damaged = tmp_path / "cut.db3"
    damaged.write_bytes(SHARED_DB3.read_bytes()[:cut])
    expected = (
        f"{damaged} at byte {cut}: the file is cut short inside its first page (the schema): "
        f"{told}; no message can be read"
    )
    got, damage = read_raw(damaged)
    assert (got, damage) == ([], [expected])
    assert [str(d) for d in bag_info(damaged).damage] == [expected]
    assert not list(Path(tempfile.gettempdir()).glob("pyconnect-salvage-*"))
    for action in ("echo", "info"):
        assert main(["bag", action, str(damaged)]) == 1
        assert capsys.readouterr().err.splitlines() == [
            f"pyconnect: {damaged}: damaged bag: {expected}"
            + ("; 0 message(s) read, the bag does not say how many it held" * (action == "echo"))
        ]
    not_sqlite = tmp_path / "not.db3"
    not_sqlite.write_bytes(b"SQLite format 2\x00" + SHARED_DB3.read_bytes()[16:cut])
    assert main(["bag", "echo", str(not_sqlite)]) == 2  # not the magic: not a bag


def _first_record_after_header(file: Path) -> int:
    """Offset of the record after the MCAP header: the first channel or chunk of the file."""
    data = file.read_bytes()
    length = struct.unpack_from("<Q", data, 9)[0]
    return 8 + 9 + length


def test_cut_before_the_channels_keeps_the_topics_and_what_was_promised(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    bag = write_chunked(tmp_path / "bag", count=300)
    file = bag / "bag_0.mcap"
    cut = _first_record_after_header(file) + 20  # inside the record holding the channel
    file.write_bytes(file.read_bytes()[:cut])
    with caplog.at_level(logging.WARNING, logger="pyconnect.record"), open_bag(bag) as reader:
        assert list(reader.topics) == ["/chatter"]
        assert reader.info.topics[0].message_count == 0
        assert sum(1 for _ in reader) == 0
        found = reader.damage
    assert len(damage_warnings(caplog)) == 1
    assert damage_warnings(caplog)[0].endswith(
        f"(and {len(found) - 1} more problem(s)); 0 message(s) read, "
        "the bag's metadata promised 300"
    )
    with open_bag(bag, topics=["/chatter"]) as reader:
        assert reader.to_pandas("/chatter").empty


def test_a_storage_file_metadata_does_not_list_is_reported(tmp_path: Path) -> None:
    bag = write_chunked(tmp_path / "bag", count=30)
    (bag / "bag_1.mcap").write_bytes((bag / "bag_0.mcap").read_bytes())
    expected = [
        f"{bag / 'metadata.yaml'}: does not list bag_1.mcap, a storage file of the bag; not read"
    ]
    with open_bag(bag) as reader:
        assert sum(1 for _ in reader) == 30
        assert [str(d) for d in reader.damage] == expected
    assert [str(d) for d in bag_info(bag).damage] == expected


def test_metadata_counts_that_lie_are_reported(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    bag = write_chunked(tmp_path / "bag", count=30)
    metadata = bag / "metadata.yaml"
    metadata.write_text(metadata.read_text().replace("message_count: 30", "message_count: 40"))
    with caplog.at_level(logging.WARNING, logger="pyconnect.record"), open_bag(bag) as reader:
        assert sum(1 for _ in reader) == 30
        assert [str(d) for d in reader.damage] == [
            f"{metadata}: /chatter: declares 40 message(s), the storage files hold 30"
        ]
    assert damage_warnings(caplog) == [
        f"{bag}: damaged bag: {metadata}: /chatter: declares 40 message(s), the storage files "
        "hold 30; 30 message(s) read, the bag's metadata promised 40"
    ]
