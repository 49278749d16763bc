"""Bags whose storage files rosbag2 compressed whole (``compression_mode: file``,
``pyconnect.record.file_compression``): read from private copies that are removed again."""

from __future__ import annotations

import errno
import os
import stat
import tempfile
from pathlib import Path

import pytest
import zstandard
from rosbags.rosbag2 import Writer
from rosbags.rosbag2.enums import CompressionFormat, CompressionMode, StoragePlugin
from rosbags.typesys import Stores, get_typestore

from pyconnect.record import file_compression
from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_info import bag_info
from pyconnect.record.bag_reader import open_bag

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
PLUGINS = {"sqlite3": StoragePlugin.SQLITE3, "mcap": StoragePlugin.MCAP}
SUFFIXES = {"sqlite3": ".db3", "mcap": ".mcap"}
VALUES = [(1_000 + i, f"hello {i}") for i in range(5)]


def write_file_compressed(path: Path, storage: str) -> Path:
    """A bag as ``ros2 bag record --compression-mode file`` (and rosbags) write it."""
    writer = Writer(path, version=9, storage_plugin=PLUGINS[storage])
    writer.set_compression(CompressionMode.FILE, CompressionFormat.ZSTD)
    string = TYPESTORE.types["std_msgs/msg/String"]
    with writer:
        connection = writer.add_connection("/chatter", "std_msgs/msg/String", typestore=TYPESTORE)
        for log_time, text in VALUES:
            data = TYPESTORE.serialize_cdr(string(data=text), "std_msgs/msg/String")
            writer.write(connection, log_time, data)
    return path


@pytest.fixture
def private_tmp(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The directory the copies go to (as TMPDIR would choose it), empty."""
    directory = tmp_path / "tmpdir"
    directory.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(directory))
    return directory


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_files_compressed_whole_are_read(tmp_path: Path, storage: str, private_tmp: Path) -> None:
    path = write_file_compressed(tmp_path / "bag", storage)
    compressed = path / f"bag{SUFFIXES[storage]}.zstd"
    assert "compression_mode: file" in (path / "metadata.yaml").read_text()
    with open_bag(path) as bag:
        (copy,) = private_tmp.iterdir()
        assert stat.S_IMODE(copy.stat().st_mode) == 0o600  # others may not read the bag
        assert copy.suffix == SUFFIXES[storage]
        assert [(m.log_time_ns, m.value) for m in bag] == VALUES
    assert (bag.errors, bag.damage) == ([], [])
    assert list(private_tmp.iterdir()) == []  # removed when the reader closes
    info = bag_info(path)
    assert (info.storage, info.files, info.message_count) == (storage, (compressed,), 5)
    assert info.damage == ()
    assert list(private_tmp.iterdir()) == []


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
@pytest.mark.parametrize("opened", ["folder", "file"])
def test_without_metadata_yaml_compressed_files_are_recognised(
    tmp_path: Path, storage: str, opened: str, private_tmp: Path
) -> None:
    path = write_file_compressed(tmp_path / "bag", storage)
    (path / "metadata.yaml").unlink()
    (compressed,) = path.iterdir()
    with open_bag(path if opened == "folder" else compressed) as bag:
        assert [(m.log_time_ns, m.value) for m in bag] == VALUES
    assert (bag.errors, bag.damage) == ([], [])
    assert list(private_tmp.iterdir()) == []


def test_a_compressed_file_that_is_no_bag_is_refused_and_its_copy_removed(
    tmp_path: Path, private_tmp: Path
) -> None:
    path = write_file_compressed(tmp_path / "bag", "mcap")
    compressed = path / "bag.mcap.zstd"
    compressed.write_bytes(zstandard.ZstdCompressor().compress(b"not a bag at all" * 10))
    with pytest.raises(BagError) as caught:
        open_bag(path)
    assert str(caught.value) == (
        f"{compressed} (decompressed): neither an MCAP nor a sqlite3 bag file"
    )
    assert list(private_tmp.iterdir()) == []


def test_a_compressed_file_cut_short_is_damage_named_by_the_compressed_file(
    tmp_path: Path, private_tmp: Path
) -> None:
    path = write_file_compressed(tmp_path / "bag", "mcap")
    compressed = path / "bag.mcap.zstd"
    whole = zstandard.ZstdDecompressor().stream_reader(compressed.read_bytes()).read()
    # Compressed in small frames, so that a cut keeps the first ones.
    frames = [whole[i : i + 64] for i in range(0, len(whole), 64)]
    data = b"".join(zstandard.ZstdCompressor().compress(frame) for frame in frames)
    compressed.write_bytes(data[: len(data) - 40])
    with open_bag(path) as bag:
        assert [(m.log_time_ns, m.value) for m in bag] == VALUES
    assert bag.damage
    assert {d.file for d in bag.damage if d.file != str(path / "metadata.yaml")} == {
        f"{compressed} (decompressed)"
    }
    assert list(private_tmp.iterdir()) == []


def test_a_full_disk_is_a_clear_error_and_leaves_no_copy(
    tmp_path: Path, private_tmp: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = write_file_compressed(tmp_path / "bag", "mcap")
    made: list[str] = []

    def full_disk(prefix: str, suffix: str) -> tuple[int, str]:
        name = str(private_tmp / f"{prefix}x{suffix}")
        Path(name).touch(mode=0o600)
        made.append(name)
        return os.open("/dev/full", os.O_WRONLY), name  # every write: ENOSPC

    monkeypatch.setattr(file_compression.tempfile, "mkstemp", full_disk)
    with pytest.raises(BagError) as caught:
        open_bag(path)
    assert str(caught.value) == (
        f"{path / 'bag.mcap.zstd'}: cannot decompress into {private_tmp}: no space left on the "
        "device after 0 bytes; set TMPDIR to a directory with room for the decompressed file"
    )
    assert made and list(private_tmp.iterdir()) == []
    assert errno.ENOSPC  # what /dev/full answers


def test_a_file_compression_other_than_zstd_is_a_clear_error(tmp_path: Path) -> None:
    path = write_file_compressed(tmp_path / "bag", "sqlite3")
    metadata = path / "metadata.yaml"
    metadata.write_text(
        metadata.read_text().replace("compression_format: zstd", "compression_format: lz4")
    )
    with pytest.raises(BagError) as caught:
        open_bag(path)
    assert str(caught.value) == (
        f"{metadata}: compression_format: expected 'zstd' for compression_mode 'file', got 'lz4'"
    )


def test_compressed_data_that_do_not_decompress_are_said(tmp_path: Path, private_tmp: Path) -> None:
    path = write_file_compressed(tmp_path / "bag", "mcap")
    compressed = path / "bag.mcap.zstd"
    data = bytearray(compressed.read_bytes())
    data[4] ^= 0xFF  # the frame header: zstd refuses the frame
    compressed.write_bytes(bytes(data))
    with pytest.raises(BagError) as caught:
        open_bag(path)
    assert str(caught.value).startswith(
        f"{compressed} (decompressed): neither an MCAP nor a sqlite3 bag file; "
        "the zstd data do not decompress after 0 bytes (zstd decompress"  # zstandard's words
    )
    assert list(private_tmp.iterdir()) == []


def test_a_reader_never_closed_leaves_no_copy(tmp_path: Path, private_tmp: Path) -> None:
    import subprocess
    import sys

    path = write_file_compressed(tmp_path / "bag", "mcap")
    script = (
        "from pyconnect.record.bag_reader import open_bag\n"
        f"print([m.value for m in open_bag({str(path)!r})])\n"  # never closed
    )
    env = {**os.environ, "TMPDIR": str(private_tmp)}
    done = subprocess.run(
        [sys.executable, "-c", script],
        check=False,
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert (done.returncode, done.stderr) == (0, "")
    assert done.stdout == f"{[text for _, text in VALUES]}\n"
    assert list(private_tmp.iterdir()) == []


def test_a_bag_command_stopped_by_sigterm_removes_the_copy(tmp_path: Path) -> None:
    """SIGTERM (timeout, docker stop) killed `bag echo` outright, and the decompressed copy of
    the bag stayed in TMPDIR."""
    import subprocess
    import sys

    bag = write_file_compressed(tmp_path / "bag", "mcap")
    copies = tmp_path / "tmpdir"
    copies.mkdir()
    # The command signals itself while it prints its first message, so the signal always lands
    # with the copy open.
    script = (
        "import os, signal, sys\n"
        "from pyconnect.commands import bag\n"
        "from pyconnect.cli import main\n"
        "def to_yaml(value):\n"
        "    os.kill(os.getpid(), signal.SIGTERM)\n"
        "    return ''\n"
        "bag.to_yaml = to_yaml\n"
        f"sys.exit(main(['bag', 'echo', {str(bag)!r}]))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script],
        env={**os.environ, "TMPDIR": str(copies)},
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 130, done.stderr  # as Ctrl-C
    assert list(copies.iterdir()) == []


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_a_compressed_file_cut_short_is_said_to_end_early(
    tmp_path: Path, storage: str, private_tmp: Path
) -> None:
    """zstandard's stream reader ends quietly where a cut file ends: the copy passed for the
    whole bag, or the storage reader called it no bag at all."""
    path = write_file_compressed(tmp_path / "bag", storage)
    compressed = path / f"bag{SUFFIXES[storage]}.zstd"
    data = compressed.read_bytes()
    compressed.write_bytes(data[: len(data) * 2 // 3])
    try:
        with open_bag(path) as reader:
            list(reader)
            said = " ".join(str(found) for found in reader.damage)
    except BagError as error:
        said = str(error)
    assert "the zstd data end early, in a frame, after" in said
    assert list(private_tmp.iterdir()) == []
