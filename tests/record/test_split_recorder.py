"""SplitRecorder: split by size and duration, and no file lost whenever the recording stops."""

from __future__ import annotations

import errno
import gc
import os
import random
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import yaml
from mcap.writer import Writer
from rclpy.serialization import serialize_message
from std_msgs.msg import String
from yaml.representer import SafeRepresenter

from pyconnect.record import open_bag, split_recorder
from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_metadata import metadata_info, metadata_yaml, read_metadata
from pyconnect.record.mcap_recorder import McapRecorder, _CountedFile
from pyconnect.record.split_recorder import SplitRecorder


def _hello(i: int) -> bytes:
    return bytes(serialize_message(String(data=f"hello {i}")))


def _metadata(bag: Path) -> dict[str, Any]:
    info: dict[str, Any] = yaml.safe_load((bag / "metadata.yaml").read_text())[
        "rosbag2_bagfile_information"
    ]
    return info


def _on_disk(bag: Path) -> list[str]:
    def order(name: str) -> int:
        match = re.fullmatch(rf"{bag.name}_(\d+)\.mcap", name)
        assert match, name
        return int(match.group(1))

    return sorted((p.name for p in bag.glob("*.mcap")), key=order)


def test_files_split_by_size_in_numeric_order(tmp_path: Path) -> None:
    bag = tmp_path / "run"
    with SplitRecorder(bag, max_bytes=1) as recorder:
        recorder.add_topic("/chatter", "std_msgs/msg/String")
        for i in range(12):
            recorder.write("/chatter", _hello(i), log_time_ns=1_000 + i)
    names = [f"run_{k}.mcap" for k in range(12)]
    assert _on_disk(bag) == names
    metadata = _metadata(bag)
    assert metadata["relative_file_paths"] == names
    assert [f["message_count"] for f in metadata["files"]] == [1] * 12
    assert (metadata["message_count"], metadata["starting_time"]) == (
        12,
        {"nanoseconds_since_epoch": 1_000},
    )
    assert metadata["duration"] == {"nanoseconds": 11}
    with open_bag(bag) as reader:
        assert [m.value for m in reader] == [f"hello {i}" for i in range(12)]


def test_files_split_by_duration(tmp_path: Path) -> None:
    bag = tmp_path / "run"
    with SplitRecorder(bag, max_ns=100) as recorder:
        recorder.add_topic("/chatter", "std_msgs/msg/String")
        for stamp in (0, 50, 99, 100, 150, 260):
            recorder.write("/chatter", _hello(stamp), log_time_ns=stamp)
    assert [f["message_count"] for f in _metadata(bag)["files"]] == [3, 2, 1]


def test_a_recording_killed_midway_lists_every_file(tmp_path: Path) -> None:
    """No close(): the process died. Every file is in metadata.yaml, the last one cut short."""
    bag = tmp_path / "run"
    recorder = SplitRecorder(bag, max_bytes=1)
    recorder.add_topic("/chatter", "std_msgs/msg/String")
    for i in range(4):
        recorder.write("/chatter", _hello(i), log_time_ns=i)
    assert (
        _metadata(bag)["relative_file_paths"]
        == _on_disk(bag)
        == [f"run_{k}.mcap" for k in range(4)]
    )
    with open_bag(bag) as reader:
        values = [m.value for m in reader]
        damage = [str(d) for d in reader.damage]
    # The open file's last chunk was still in memory: the first three files are whole.
    assert values == ["hello 0", "hello 1", "hello 2"]
    assert len(damage) == 1 and damage[0].startswith(f"{bag / 'run_3.mcap'} at byte "), damage
    recorder.close()  # what the dead process could not do; the bag is then whole
    with open_bag(bag) as reader:
        assert [m.value for m in reader] == [f"hello {i}" for i in range(4)]
        assert reader.damage == []


class Interrupt(KeyboardInterrupt):
    """Ctrl-C, raised where a signal handler could raise it."""


def _interrupt_at(where: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Make the next file's creation (or the open file's finish) raise ``Interrupt``."""
    if where == "before the file":
        original_init = McapRecorder.__init__

        def init(self: McapRecorder, *args: Any, **kwargs: Any) -> None:
            monkeypatch.setattr(McapRecorder, "__init__", original_init)
            raise Interrupt

        monkeypatch.setattr(McapRecorder, "__init__", init)
    elif where == "before its header":

        def start(self: Writer, *args: Any, **kwargs: Any) -> None:
            monkeypatch.undo()
            raise Interrupt

        monkeypatch.setattr(Writer, "start", start)
    elif where == "while adding topics":

        def add_topic(self: McapRecorder, *args: Any, **kwargs: Any) -> None:
            monkeypatch.undo()
            raise Interrupt

        monkeypatch.setattr(McapRecorder, "add_topic", add_topic)
    else:  # while the full file is finished

        def close(self: McapRecorder) -> None:
            monkeypatch.undo()
            raise Interrupt

        monkeypatch.setattr(McapRecorder, "close", close)


@pytest.mark.parametrize(
    "where",
    ["before the file", "before its header", "while adding topics", "while finishing the last"],
)
def test_an_interrupt_inside_a_split_loses_no_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, where: str
) -> None:
    bag = tmp_path / "run"
    recorder = SplitRecorder(bag, max_bytes=1)
    recorder.add_topic("/chatter", "std_msgs/msg/String")
    recorder.add_topic("/other", "std_msgs/msg/String")
    for i in range(3):
        recorder.write("/chatter", _hello(i), log_time_ns=i)
    _interrupt_at(where, monkeypatch)
    with pytest.raises(Interrupt):
        recorder.write("/chatter", _hello(3), log_time_ns=3)  # splits: the 4th file
    recorder.close()
    files = _on_disk(bag)
    assert _metadata(bag)["relative_file_paths"] == files
    assert files[:3] == ["run_0.mcap", "run_1.mcap", "run_2.mcap"]
    with open_bag(bag) as reader:
        values = [m.value for m in reader]
        assert (reader.errors, reader.damage) == ([], [])
    assert values == ["hello 0", "hello 1", "hello 2"]  # the interrupted write wrote nothing
    assert _metadata(bag)["message_count"] == 3


def test_closed_recorders_refuse_writes_and_new_directories_only(tmp_path: Path) -> None:
    bag = tmp_path / "run"
    recorder = SplitRecorder(bag)
    recorder.close()
    recorder.close()
    assert _metadata(bag)["relative_file_paths"] == ["run_0.mcap"]  # empty, still a bag
    with pytest.raises(Exception) as closed:
        recorder.write("/chatter", _hello(0), log_time_ns=0)
    assert str(closed.value) == f"{bag}: recording is closed"
    with pytest.raises(Exception) as exists:
        SplitRecorder(bag)
    assert str(exists.value) == f"{bag}: already exists; a new recording needs a new one"


def test_the_first_file_and_the_definitions_are_ready_when_a_topic_is_added(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The first message and each split cost a write, not an import and a definition lookup
    (done in a subscription callback, the first file's ~0.1 s lost 22-34 messages at 1 kHz)."""
    from pyconnect.typesys import installed_definition_text

    bag = tmp_path / "run"
    recorder = SplitRecorder(bag, max_bytes=1)
    recorder.add_topic("/chatter", "std_msgs/msg/String")
    assert _on_disk(bag) == ["run_0.mcap"] == _metadata(bag)["relative_file_paths"]
    assert (bag / "run_0.mcap").read_bytes().startswith(b"\x89MCAP0\r\n")

    def no_lookup(msg_type: str) -> str:
        raise AssertionError(f"{msg_type}: definition looked up again")

    monkeypatch.setattr(installed_definition_text, "installed_definition", no_lookup)
    for i in range(3):  # three files: each split reuses the definition read above
        recorder.write("/chatter", _hello(i), log_time_ns=i)
    recorder.close()
    assert _on_disk(bag) == ["run_0.mcap", "run_1.mcap", "run_2.mcap"]
    with open_bag(bag) as reader:
        assert [m.value for m in reader] == ["hello 0", "hello 1", "hello 2"]


OTHER_HASH = "RIHS01_" + "ab" * 32  # a String that is not the installed one


def test_the_type_hash_is_stored_in_every_file_and_metadata_yaml_as_rosbag2_does(
    tmp_path: Path,
) -> None:
    """add_topic took no hash: metadata.yaml's type_description_hash was always '', the MCAP
    channels' topic_type_hash too, so open_bag could never tell a type that changed."""
    from mcap.reader import make_reader

    from pyconnect.typesys.packages import installed_type_hash

    installed = installed_type_hash("std_msgs/msg/String")
    assert installed is not None and installed.startswith("RIHS01_")
    bag = tmp_path / "run"
    with SplitRecorder(bag, max_bytes=1) as recorder:
        recorder.add_topic("/chatter", "std_msgs/msg/String", type_hash=installed)
        recorder.add_topic("/changed", "std_msgs/msg/String", type_hash=OTHER_HASH)
        recorder.add_topic("/unknown", "std_msgs/msg/String")
        for i in range(3):  # three files: each split declares the topics again
            recorder.write("/chatter", _hello(i), log_time_ns=3 * i)
            recorder.write("/changed", _hello(i), log_time_ns=3 * i + 1)
            recorder.write("/unknown", _hello(i), log_time_ns=3 * i + 2)
    stored = {"/chatter": installed, "/changed": OTHER_HASH, "/unknown": ""}
    listed = _metadata(bag)["topics_with_message_count"]
    assert {t["topic_metadata"]["name"]: t["topic_metadata"]["type_description_hash"]
            for t in listed} == stored  # fmt: skip
    assert len(_on_disk(bag)) == 9
    for name in _on_disk(bag):
        with (bag / name).open("rb") as stream:
            reader = make_reader(stream)
            summary = reader.get_summary()
            assert summary is not None
            channels = {c.topic: c.metadata["topic_type_hash"] for c in summary.channels.values()}
            assert channels == stored, name
            (record,) = [m for m in reader.iter_metadata() if m.name == "rosbag2"]
        inside = yaml.safe_load(record.metadata["serialized_metadata"])
        assert {t["topic_metadata"]["name"]: t["topic_metadata"]["type_description_hash"]
                for t in inside["topics_with_message_count"]} == stored  # fmt: skip
    with open_bag(bag) as reader:
        assert {name: topic.type_hash for name, topic in reader.topics.items()} == stored
        assert len(list(reader)) == 9
    # The documented check now fires: the stored hash that is not the installed type's.
    assert [(m.topic, m.bag_hash, m.installed_hash) for m in reader.mismatches] == [
        ("/changed", OTHER_HASH, installed)
    ]


def _image(fill: bytes) -> bytes:
    """A mono8 Image of 100 kB (CDR, header left empty), pixels from ``fill``."""
    from sensor_msgs.msg import Image

    image = Image(height=100, width=1000, encoding="mono8", step=1000)
    image.data = fill
    return bytes(serialize_message(image))


def test_max_bytes_is_the_size_of_the_file_as_ros2_bag_record_b(tmp_path: Path) -> None:
    """20 MB of blank images compress to a few kB: ``ros2 bag record -b 1000000`` writes one
    file. Counted as message bytes, the same limit cut them into 20 near-empty files."""
    bag = tmp_path / "blank"
    with SplitRecorder(bag, max_bytes=1_000_000) as recorder:
        recorder.add_topic("/image", "sensor_msgs/msg/Image")
        blank = _image(bytes(100_000))
        for i in range(200):
            recorder.write("/image", blank, log_time_ns=i)
    assert _on_disk(bag) == ["blank_0.mcap"]
    assert (bag / "blank_0.mcap").stat().st_size < 1_000_000


def test_files_split_at_the_first_chunk_that_reaches_max_bytes(tmp_path: Path) -> None:
    """Noise does not compress: each file ends at the chunk that takes it past the limit."""
    bag = tmp_path / "noise"
    limit = 300_000
    noise = random.Random(5)
    with SplitRecorder(bag, max_bytes=limit) as recorder:
        recorder.add_topic("/image", "sensor_msgs/msg/Image")
        for i in range(30):
            recorder.write("/image", _image(noise.randbytes(100_000)), log_time_ns=i)
    sizes = [(bag / name).stat().st_size for name in _on_disk(bag)]
    assert len(sizes) > 3
    # A chunk holds up to `limit` bytes of messages: a file passes the limit by less than one
    # chunk (and the indexes and summary written when it is finished).
    assert all(limit <= size < 2 * limit + 20_000 for size in sizes[:-1]), sizes
    assert sum(_metadata(bag)["files"][k]["message_count"] for k in range(len(sizes))) == 30


@pytest.mark.parametrize(("option", "value"), [("max_bytes", -1), ("max_ns", -1_000_000_000)])
def test_negative_limits_are_refused(tmp_path: Path, option: str, value: int) -> None:
    # A negative limit is always reached: it used to give every message a file of its own.
    with pytest.raises(ValueError) as refused:
        SplitRecorder(tmp_path / "run", **{option: value})
    assert str(refused.value) == f"{option}: expected 0 (no split) or more, got {value}"
    assert not (tmp_path / "run").exists()


# -- the cost of a split -------------------------------------------------------------------------
def _split_often(bag: Path, files: int) -> SplitRecorder:
    recorder = SplitRecorder(bag, max_ns=100)
    recorder.add_topic("/chatter", "std_msgs/msg/String")
    for i in range(files * 2):  # two messages a file
        recorder.write("/chatter", _hello(i), log_time_ns=i * 50)
    return recorder


def test_each_files_metadata_is_serialised_a_fixed_number_of_times(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """metadata.yaml is rewritten at every split; every file's entry in it was serialised
    again each time, so a split cost more with each file (183 ms at 1,200 files)."""
    represent_dict = SafeRepresenter.yaml_representers[dict]
    entries = 0

    def counting(representer: SafeRepresenter, data: dict[Any, Any]) -> Any:
        nonlocal entries
        entries += "path" in data  # a file's entry, in metadata.yaml or an MCAP file's copy
        return represent_dict(representer, data)

    monkeypatch.setitem(SafeRepresenter.yaml_representers, dict, counting)
    bag = tmp_path / "run"
    _split_often(bag, 60).close()
    assert len(_metadata(bag)["files"]) == 60
    # Each file's entry: once in its MCAP file, once when it is opened, once when finished.
    assert entries == 3 * 60


def test_a_finished_files_recorder_is_let_go(tmp_path: Path) -> None:
    """Each finished file's McapRecorder (its schemas and indexes) used to stay referenced
    until the recording ended: ~10 kB a file, a day of 3 s splits is 29k files."""
    bag = tmp_path / "run"
    recorder = _split_often(bag, 30)
    gc.collect()
    alive = [o for o in gc.get_objects() if isinstance(o, McapRecorder)]
    assert [o.file_path for o in alive if o.file_path.parent == bag] == [bag / "run_29.mcap"]
    recorder.close()
    assert recorder.files == [f"run_{k}.mcap" for k in range(30)]


def test_metadata_is_the_text_of_one_dump_of_the_whole(tmp_path: Path) -> None:
    """The finished files' items are written apart and joined: the text is still the one a
    dump of the whole metadata gives (names that YAML quotes, or folds past 80 columns)."""
    for name in ("run", "yes", "a b " * 25, "x: #y", "é"):
        bag = tmp_path / name
        with _split_often(bag, 4) as recorder:
            recorder.add_topic("/other", "std_msgs/msg/String", offered_qos_profiles="- a: 1\n")
        text = (bag / "metadata.yaml").read_text(encoding="utf-8")
        whole = {"rosbag2_bagfile_information": metadata_info(read_metadata(bag / "metadata.yaml"))}
        assert text == metadata_yaml(whole)
        assert len(_metadata(bag)["files"]) == 4
        with open_bag(bag) as reader:
            assert len(list(reader)) == 8


# -- a full disk ----------------------------------------------------------------------------------
def no_space() -> OSError:
    return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def full_disk_write(room: int) -> Callable[[_CountedFile, bytes], int]:
    """A ``_CountedFile.write`` for a disk with ``room`` bytes left for the bag's MCAP files: a
    write past it writes what still fits, then raises ENOSPC, as a full disk does. Its
    ``left()`` (an attribute of the function) says how much room is left."""
    left = room

    def write(self: _CountedFile, data: bytes) -> int:
        nonlocal left
        fits = min(len(data), left)
        if fits:
            self.stream.write(bytes(data)[:fits])
            self.written += fits
            left -= fits
        if fits < len(data):
            raise no_space()
        return fits

    write.left = lambda: left  # type: ignore[attr-defined]
    return write


def fill_disk(monkeypatch: pytest.MonkeyPatch, room: int) -> None:
    """The bag's MCAP files get ``room`` bytes. Once they have taken it, metadata.yaml has only
    the room of its old copy: an atomic rewrite, which needs room for the new one beside it,
    fails while the old one exists."""
    write = full_disk_write(room)
    monkeypatch.setattr(_CountedFile, "write", write)
    write_metadata = split_recorder.write_metadata

    def metadata_if_room(path: Path, metadata: Any, **options: Any) -> None:
        if path.exists() and not write.left():  # type: ignore[attr-defined]
            raise no_space()
        write_metadata(path, metadata, **options)

    monkeypatch.setattr(split_recorder, "write_metadata", metadata_if_room)


def _noise(i: int) -> bytes:
    return bytes(serialize_message(String(data=f"{i:04d}" + "x" * 996)))


def test_a_file_the_full_disk_cut_short_is_counted_as_read_back(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    bag = tmp_path / "run"
    recorder = SplitRecorder(bag, compression="none")  # a cut chunk keeps its first messages
    recorder.add_topic("/noise", "std_msgs/msg/String")
    fill_disk(monkeypatch, 10_000)
    for i in range(40):  # one chunk in memory: it meets the full disk when the file is finished
        recorder.write("/noise", _noise(i), log_time_ns=1_000 + i)
    with pytest.raises(OSError) as failed:
        recorder.close()
    assert failed.value.errno == errno.ENOSPC
    recorder.close()  # the file is what it is: not finished again
    with open_bag(bag) as reader:
        stamps = [m.log_time_ns for m in reader]
    assert 0 < len(stamps) < 40
    assert stamps == list(range(1_000, 1_000 + len(stamps)))
    # What the bag holds, not what was handed to it: counts and metadata say the same.
    assert recorder.counts == {"/noise": len(stamps)}
    metadata = _metadata(bag)
    assert metadata["message_count"] == len(stamps)
    assert [t["message_count"] for t in metadata["topics_with_message_count"]] == [len(stamps)]
    assert metadata["files"] == [
        {
            "path": "run_0.mcap",
            "starting_time": {"nanoseconds_since_epoch": 1_000},
            "duration": {"nanoseconds": len(stamps) - 1},
            "message_count": len(stamps),
        }
    ]


# -- a directory removed while it is recorded ------------------------------------------------------
def test_a_directory_removed_at_a_split_is_a_bag_error_not_made_again(tmp_path: Path) -> None:
    # It was made again, empty, at the next split: the recording went on into it, and its
    # metadata.yaml listed the files removed with the first one.
    bag = tmp_path / "run"
    recorder = SplitRecorder(bag, max_ns=10)
    recorder.add_topic("/chatter", "std_msgs/msg/String")
    for i in range(3):
        recorder.write("/chatter", _hello(i), log_time_ns=1_000 + 10 * i)  # a file each
    for path in bag.iterdir():
        path.unlink()
    bag.rmdir()
    expected = f"{bag}: the directory was removed while it was recorded, its files with it"
    with pytest.raises(BagError) as failed:
        recorder.write("/chatter", _hello(3), log_time_ns=1_030)  # the next file's split
    assert str(failed.value) == expected
    assert isinstance(failed.value.__cause__, FileNotFoundError)
    assert not bag.exists()
    assert recorder.counts == {"/chatter": 0}  # its files went with it
    with pytest.raises(BagError) as closing:
        recorder.close()
    assert closing.value is failed.value  # one failure, told the same way
    assert not bag.exists()
    recorder.close()  # idempotent: reported once


def test_a_directory_removed_with_its_only_file_open_is_a_bag_error_at_close(
    tmp_path: Path,
) -> None:
    bag = tmp_path / "run"
    recorder = SplitRecorder(bag)
    recorder.add_topic("/chatter", "std_msgs/msg/String")
    recorder.write("/chatter", _hello(0), log_time_ns=1_000)
    for path in bag.iterdir():
        path.unlink()
    bag.rmdir()
    recorder.write("/chatter", _hello(1), log_time_ns=1_001)  # into the open (unlinked) file
    with pytest.raises(BagError, match="the directory was removed while it was recorded"):
        recorder.close()
    assert not bag.exists()
    assert recorder.counts == {"/chatter": 0}
