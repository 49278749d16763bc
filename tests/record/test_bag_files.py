"""Finding and opening a bag's storage files (``bag_files``): bags whose messages rosbag2
compressed one by one (``compression_mode: message``)."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest
from rosbags.rosbag2 import Reader, Writer
from rosbags.rosbag2.enums import CompressionFormat, CompressionMode, StoragePlugin
from rosbags.typesys import Stores, get_typestore

from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_reader import open_bag

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
PLUGINS = {"sqlite3": StoragePlugin.SQLITE3, "mcap": StoragePlugin.MCAP}


def write_compressed(path: Path, storage: str, count: int = 5) -> Path:
    """A bag as ``rosbag2`` (and rosbags) write it with per-message zstd compression."""
    writer = Writer(path, version=9, storage_plugin=PLUGINS[storage])
    writer.set_compression(CompressionMode.MESSAGE, CompressionFormat.ZSTD)
    string = TYPESTORE.types["std_msgs/msg/String"]
    with writer:
        connection = writer.add_connection("/chatter", "std_msgs/msg/String", typestore=TYPESTORE)
        for i in range(count):
            data = TYPESTORE.serialize_cdr(string(data=f"hello {i}"), "std_msgs/msg/String")
            writer.write(connection, 1_000 + i, data)
    return path


def plain_messages(path: Path) -> list[tuple[int, bytes]]:
    """(log time, CDR bytes) as rosbags reads them: decompressed."""
    with Reader(path) as reader:
        return [(t, bytes(raw)) for _, t, raw in reader.messages()]


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_messages_compressed_one_by_one_are_decompressed(tmp_path: Path, storage: str) -> None:
    path = write_compressed(tmp_path / "bag", storage)
    assert "compression_mode: message" in (path / "metadata.yaml").read_text()
    with open_bag(path) as bag:
        values = [(m.log_time_ns, m.value) for m in bag]
    assert values == [(1_000 + i, f"hello {i}") for i in range(5)]
    assert (bag.errors, bag.damage) == ([], [])
    # raw bytes are the CDR a player publishes, not zstd frames
    with open_bag(path, raw=True) as bag:
        raw = [(m.log_time_ns, bytes(m.value)) for m in bag]
    assert raw == plain_messages(path)
    assert raw[0][1].startswith(b"\x00\x01\x00\x00")


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
@pytest.mark.parametrize("opened", ["folder", "file"])
def test_without_metadata_yaml_zstd_frames_are_recognised(
    tmp_path: Path, storage: str, opened: str
) -> None:
    """Only metadata.yaml says a bag compresses its messages: a storage file read without it
    (a bare .mcap, a folder before ``ros2 bag reindex``) decoded the zstd frames as CDR, every
    message an error, and ``raw=True`` handed them out (a player would publish them)."""
    path = write_compressed(tmp_path / "bag", storage)
    expected = plain_messages(path)
    (path / "metadata.yaml").unlink()
    (storage_file,) = (p for p in path.iterdir())
    target = path if opened == "folder" else storage_file
    with open_bag(target) as bag:
        values = [(m.log_time_ns, m.value) for m in bag]
    assert values == [(1_000 + i, f"hello {i}") for i in range(5)]
    assert (bag.errors, bag.damage) == ([], [])
    with open_bag(target, raw=True) as bag:
        assert [(m.log_time_ns, bytes(m.value)) for m in bag] == expected


def test_without_metadata_yaml_plain_cdr_is_read_as_it_is(tmp_path: Path) -> None:
    path = tmp_path / "bag"
    writer = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
    string = TYPESTORE.types["std_msgs/msg/String"]
    with writer:
        connection = writer.add_connection("/chatter", "std_msgs/msg/String", typestore=TYPESTORE)
        writer.write(connection, 5, TYPESTORE.serialize_cdr(string(data="x"), "std_msgs/msg/String"))
    (path / "metadata.yaml").unlink()
    with open_bag(path) as bag:
        assert [m.value for m in bag] == ["x"]
    assert (bag.errors, bag.damage) == ([], [])


def test_compression_mode_is_read_case_insensitively(tmp_path: Path) -> None:
    path = write_compressed(tmp_path / "bag", "mcap")
    metadata = path / "metadata.yaml"
    text = metadata.read_text()
    metadata.write_text(
        text.replace("compression_mode: message", "compression_mode: MESSAGE").replace(
            "compression_format: zstd", "compression_format: ZSTD"
        )
    )
    with open_bag(path) as bag:
        assert [m.value for m in bag] == [f"hello {i}" for i in range(5)]


def test_unsupported_message_compression_is_a_clear_error(tmp_path: Path) -> None:
    path = write_compressed(tmp_path / "bag", "sqlite3")
    metadata = path / "metadata.yaml"
    metadata.write_text(
        metadata.read_text().replace("compression_format: zstd", "compression_format: lz4")
    )
    with pytest.raises(BagError) as caught:
        open_bag(path)
    assert str(caught.value) == (
        f"{metadata}: compression_format: expected 'zstd' for compression_mode 'message', "
        "got 'lz4'; decompress the bag with `ros2 bag convert` first"
    )


def test_a_message_that_does_not_decompress_is_damage(tmp_path: Path) -> None:
    path = write_compressed(tmp_path / "bag", "sqlite3")
    (db3,) = path.glob("*.db3")
    with sqlite3.connect(db3) as db:
        (frame,) = db.execute("SELECT data FROM messages WHERE timestamp = 1002").fetchone()
        db.execute("UPDATE messages SET data = ? WHERE timestamp = 1002", (frame[:-4],))
        db.execute("UPDATE messages SET data = x'0001000000' WHERE timestamp = 1003")
    db.close()
    with open_bag(path) as bag:
        values = [m.value for m in bag]
    assert values == ["hello 0", "hello 1", "hello 4"]
    assert bag.errors == []
    (damage,) = bag.damage
    assert damage.file == str(db3)
    assert damage.what.startswith("messages whose data does not decompress (zstd: ")


@pytest.mark.parametrize("declares_its_size", [True, False])
def test_a_message_that_decompresses_to_too_much_is_damage_not_memory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, declares_its_size: bool
) -> None:
    """A few kB of zstd expand to gigabytes (a 128 kB frame to 4 GB): the whole frame was
    decompressed in memory, and the MemoryError ended the read. Here the bound is made small."""
    import zstandard

    from pyconnect.record import message_compression

    monkeypatch.setattr(message_compression, "MAX_MESSAGE_BYTES", 1 << 20)
    path = write_compressed(tmp_path / "bag", "sqlite3")
    (db3,) = path.glob("*.db3")
    compressor = zstandard.ZstdCompressor(write_content_size=declares_its_size)
    bomb = compressor.compress(bytes(8 << 20))  # 8 MiB of zeros: a few hundred bytes
    with sqlite3.connect(db3) as db:
        db.execute("UPDATE messages SET data = ? WHERE timestamp = 1002", (bomb,))
    db.close()
    with open_bag(path) as bag:
        values = [m.value for m in bag]
    assert values == ["hello 0", "hello 1", "hello 3", "hello 4"]
    (damage,) = bag.damage
    assert damage.what == (f"messages that decompress (zstd) to more than {1 << 20} bytes skipped")


def write_split(path: Path, files: int = 3) -> Path:
    """A split bag of ``files`` files, one /x Int64 message (its index) in each."""
    from pyconnect.record.split_recorder import SplitRecorder

    with SplitRecorder(path, max_ns=1) as recorder:
        recorder.add_topic("/x", "std_msgs/msg/Int64")
        for i in range(files):
            cdr = b"\x00\x01\x00\x00" + i.to_bytes(8, "little")
            recorder.write("/x", cdr, log_time_ns=1_000 + i * 10)
    assert sorted(p.name for p in path.glob("*.mcap")) == [
        f"{path.name}_{i}.mcap" for i in range(files)
    ]
    return path


def test_a_listed_file_that_is_missing_is_damage_and_the_others_are_read(tmp_path: Path) -> None:
    # One missing split file made open_bag raise, and not one intact message was read.
    path = write_split(tmp_path / "bag")
    (path / "bag_1.mcap").unlink()
    with open_bag(path) as bag:
        assert [m.value for m in bag] == [0, 2]
        assert [str(item) for item in bag.damage] == [
            f"{path / 'metadata.yaml'}: lists bag_1.mcap, which is not in the bag; "
            "its messages are not read"
        ]
    assert bag.info.files == (path / "bag_0.mcap", path / "bag_2.mcap")


def test_a_bag_with_none_of_its_listed_files_is_an_error(tmp_path: Path) -> None:
    path = write_split(tmp_path / "bag", files=2)
    for file in path.glob("*.mcap"):
        file.unlink()
    with pytest.raises(BagError) as caught:
        open_bag(path)
    assert str(caught.value) == (
        f"{path}: metadata.yaml lists 'bag_0.mcap', 'bag_1.mcap', none of which is in the bag"
    )
