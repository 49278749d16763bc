"""open_bag's access options: named tuples, raw CDR, several bags, type filters, registry=,
RIHS01 checks, decode failures reported per topic, and reading in bounded windows."""

from __future__ import annotations

import copy
import logging
import pickle
import tracemalloc
from pathlib import Path
from typing import Any

import pytest
from rclpy.serialization import deserialize_message, serialize_message
from std_msgs.msg import String
from test_msgs.msg import BasicTypes

from pyconnect.codecs.registry import Registry
from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_info import bag_info
from pyconnect.record.bag_reader import BagMessage, open_bag
from pyconnect.record.mcap_recorder import McapRecorder


def chatter(i: int) -> bytes:
    return bytes(serialize_message(String(data=f"hello {i}")))


def write(path: Path, times: list[int], *, topic: str = "/chatter", **options: Any) -> Path:
    with McapRecorder(path) as recorder:
        recorder.add_topic(topic, "std_msgs/msg/String", **options)
        recorder.add_topic("/basic", "test_msgs/msg/BasicTypes")
        for i, stamp in enumerate(times):
            recorder.write(topic, chatter(i), log_time_ns=stamp)
            basic = bytes(serialize_message(BasicTypes(int32_value=i)))
            recorder.write("/basic", basic, log_time_ns=stamp + 1)
    return path


def write_images(
    path: Path, count: int, shape: tuple[int, int, int], *, compression: str, chunk_size: int
) -> Path:
    """A bag of ``count`` images on /camera, image ``i`` filled with byte ``i``."""
    from sensor_msgs.msg import Image

    height, width, channels = shape
    with McapRecorder(path, compression=compression, chunk_size=chunk_size) as recorder:
        recorder.add_topic("/camera", "sensor_msgs/msg/Image")
        for i in range(count):
            image = Image(height=height, width=width, step=width * channels,
                          encoding="rgb8" if channels == 3 else "mono8")  # fmt: skip
            image.data = bytes([i]) * (height * width * channels)
            recorder.write("/camera", bytes(serialize_message(image)), log_time_ns=i)
    return path


def test_items_are_named_tuples(tmp_path: Path) -> None:
    with open_bag(write(tmp_path / "bag", [10]), topics=["/chatter"]) as bag:
        (item,) = list(bag)
    assert isinstance(item, tuple)
    assert (item.topic, item[0], item[1], item[2], item.msg_type) == (
        "/chatter", "/chatter", 10, "hello 0", "std_msgs/msg/String"
    )  # fmt: skip
    topic, stamp, value = item
    assert (topic, stamp, value) == ("/chatter", 10, "hello 0")
    assert item == ("/chatter", 10, "hello 0")
    assert BagMessage("/t", 1, 2, "p/msg/T")._asdict() == {
        "topic": "/t",
        "log_time_ns": 1,
        "value": 2,
    }


def test_items_pickle_copy_and_replace_with_their_type(tmp_path: Path) -> None:
    with open_bag(write(tmp_path / "bag", [10]), topics=["/chatter"]) as bag:
        (item,) = list(bag)
    assert isinstance(item, BagMessage)
    again = pickle.loads(pickle.dumps(item))
    assert (again, again.msg_type, type(again)) == (item, "std_msgs/msg/String", BagMessage)
    assert copy.copy(item).msg_type == "std_msgs/msg/String"
    replaced = item._replace(value="bye")
    assert (replaced, replaced.msg_type) == (("/chatter", 10, "bye"), "std_msgs/msg/String")
    assert repr(item) == (
        "BagMessage(topic='/chatter', log_time_ns=10, msg_type='std_msgs/msg/String', "
        "value='hello 0')"
    )


def test_raw_gives_cdr_bytes_and_the_type_per_topic(tmp_path: Path) -> None:
    with open_bag(write(tmp_path / "bag", [10, 20]), raw=True, topics=["/chatter"]) as bag:
        items = list(bag)
        assert bag.topics["/chatter"].msg_type == "std_msgs/msg/String"
    assert [(i.topic, i.log_time_ns, i.value) for i in items] == [
        ("/chatter", 10, chatter(0)),
        ("/chatter", 20, chatter(1)),
    ]
    assert all(type(i.value) is bytes and i.msg_type == "std_msgs/msg/String" for i in items)
    assert deserialize_message(items[1].value, String).data == "hello 1"


def test_several_bags_merge_in_time_order(tmp_path: Path) -> None:
    first = write(tmp_path / "a.mcap", [10, 30, 50])
    second = write(tmp_path / "b", [20, 40])
    with open_bag([first, second], topics=["/chatter"]) as bag:
        assert [(m.log_time_ns, m.value) for m in bag] == [
            (10, "hello 0"), (20, "hello 0"), (30, "hello 1"), (40, "hello 1"), (50, "hello 2")
        ]  # fmt: skip
        assert bag.topics["/chatter"].message_count == 5
        assert bag.info.files == (first, second / "b_0.mcap")


def test_an_empty_list_of_bags_names_the_function_called() -> None:
    with pytest.raises(BagError) as opening:
        open_bag([])
    with pytest.raises(BagError) as describing:
        bag_info([])
    assert str(opening.value) == "open_bag: no bag given (an empty list)"
    assert str(describing.value) == "bag_info: no bag given (an empty list)"


def test_types_filter_alone_and_with_topics(tmp_path: Path) -> None:
    bag_path = write(tmp_path / "bag", [10, 20])
    with open_bag(bag_path, types=["test_msgs/BasicTypes"]) as bag:
        assert {m.topic for m in bag} == {"/basic"}
    with open_bag(bag_path, types=["std_msgs/msg/String"], topics=["/basic", "/chatter"]) as bag:
        assert [m.value for m in bag] == ["hello 0", "hello 1"]
    # A type no topic of the bag has is refused (tests/record/test_topic_selection.py).
    with pytest.raises(BagError):
        open_bag(bag_path, types=["sensor_msgs/msg/Image"])


class ShoutingCodec:
    msg_type = "std_msgs/msg/String"
    lossless = False

    def encode(self, value: Any) -> Any:
        return String(data=str(value).lower())

    def decode(self, msg: Any) -> Any:
        return msg.data.upper()

    def to_fields(self, value: Any) -> dict[str, Any]:
        return {"data": str(value).lower()}


def test_registry_on_reading_and_recording(tmp_path: Path) -> None:
    registry = Registry()
    registry.register("std_msgs/msg/String", ShoutingCodec())
    with McapRecorder(tmp_path / "bag.mcap", registry=registry) as recorder:
        recorder.add_topic("/chatter", "std_msgs/msg/String")
        recorder.write_value("/chatter", "Hello", log_time_ns=1)
    with open_bag(tmp_path / "bag.mcap", registry=registry) as bag:
        assert [m.value for m in bag] == ["HELLO"]
    with open_bag(tmp_path / "bag.mcap") as bag:  # the default registry: plain str
        assert [m.value for m in bag] == ["hello"]


def test_type_hash_mismatch_is_reported_and_the_bag_definition_used(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    stale = "RIHS01_" + "ab" * 32
    # A String that, in this bag, has an extra field: the stored definition describes it.
    definition = "string data\nint32 extra\n"
    with McapRecorder(tmp_path / "bag.mcap") as recorder:
        recorder.add_topic(
            "/chatter", "std_msgs/msg/String", definition=definition, type_hash=stale
        )
        recorder.write("/chatter", chatter(0)[: -0 or None] + b"\x00" * 4, log_time_ns=1)
    with (
        caplog.at_level(logging.WARNING, logger="pyconnect.record"),
        open_bag(tmp_path / "bag.mcap", natural=False) as bag,
    ):
        values = [m.value for m in bag]
    installed = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
    message = (
        f"/chatter: std_msgs/msg/String in the bag ({stale}) is not the installed "
        f"std_msgs/msg/String ({installed}); decoding with the definition stored in the bag"
    )
    assert [str(m) for m in bag.mismatches] == [message]
    assert [r.getMessage() for r in caplog.records] == [f"{tmp_path / 'bag.mcap'}: {message}"]
    assert values == [{"data": "hello 0", "extra": 0}]


def test_undecodable_messages_warn_once_per_topic_then_summarise(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    with McapRecorder(tmp_path / "bag.mcap") as recorder:
        recorder.add_topic("/a", "std_msgs/msg/String")
        recorder.add_topic("/b", "std_msgs/msg/String")
        for i in range(3):
            recorder.write("/a", b"\x00\x01\x00\x00\xff\xff\xff\x7f", log_time_ns=i)
            recorder.write("/b", b"\x00\x01\x00\x00\xff\xff\xff\x7f", log_time_ns=i)
            recorder.write("/b", chatter(i), log_time_ns=i)
    with (
        caplog.at_level(logging.WARNING, logger="pyconnect.record"),
        open_bag(tmp_path / "bag.mcap") as bag,
    ):
        assert [m.value for m in bag] == ["hello 0", "hello 1", "hello 2"]
    lines = [r.getMessage() for r in caplog.records]
    first_a, first_b = (str(p) for p in (bag.errors[0], bag.errors[1]))
    assert lines == [
        f"{tmp_path / 'bag.mcap'}: {first_a}; the read goes on (a summary follows at its end)",
        f"{tmp_path / 'bag.mcap'}: {first_b}; the read goes on (a summary follows at its end)",
        f"{tmp_path / 'bag.mcap'}: 6 message(s) not decoded (/a: 3, /b: 3); first: {first_a}",
    ]


def test_a_cut_recording_is_read_in_bounded_windows(tmp_path: Path) -> None:
    """A cut file of 40 chunks is read holding about two chunks, not the whole file."""
    payload = "x" * 20_000
    path = tmp_path / "big.mcap"
    with McapRecorder(path, compression="none", chunk_size=200_000) as recorder:
        recorder.add_topic("/chatter", "std_msgs/msg/String")
        for i in range(400):
            data = bytes(serialize_message(String(data=f"{i:05d}{payload}")))
            recorder.write("/chatter", data, log_time_ns=i)
    data = path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) - 200])  # inside the summary
    assert len(data) > 40 * 200_000
    with open_bag(cut, raw=True) as bag:
        assert bag.damage  # the cut is seen when the file is opened
        tracemalloc.start()
        try:
            count = 0
            for item in bag:
                assert int(item.value[8:13]) == count  # in time order
                count += 1
            _, peak = tracemalloc.get_traced_memory()
        finally:
            tracemalloc.stop()
    assert count == 400
    assert peak < 2 * 220_000 + 3 * 20_100 + 100_000, peak  # two chunks and a few messages


def test_natural_images_are_read_holding_one_chunk_and_one_message(tmp_path: Path) -> None:
    """Natural images are views on their chunk; the caller holding the last one while the next
    chunk loads must not keep two chunks alive (the last message of a chunk is a copy)."""
    path = write_images(tmp_path / "images.mcap", 60, (100, 200, 3), compression="none",
                        chunk_size=300_000)  # fmt: skip
    with open_bag(path) as bag:
        list(bag)  # the decoder is built once, outside the measurement
        tracemalloc.start()
        try:
            count = 0
            for item in bag:
                assert item.value.shape == (100, 200, 3)
                assert int(item.value[99, 199, 2]) == count
                count += 1
            _, peak = tracemalloc.get_traced_memory()
        finally:
            tracemalloc.stop()
    assert count == 60
    # A chunk holds five images (300 kB); two chunks would be 600 kB.
    assert peak < 360_000 + 2 * 60_100 + 50_000, peak


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_chunks_in_memory_maps_read_alike(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, compression: str
) -> None:
    """Big chunks are decompressed into memory maps of their own: the same messages come out,
    also from a file cut short (here every chunk takes that path)."""
    from pyconnect.record import mcap_chunks

    path = tmp_path / "bag.mcap"
    with McapRecorder(path, compression=compression, chunk_size=4_000) as recorder:
        recorder.add_topic("/chatter", "std_msgs/msg/String")
        for i in range(200):
            recorder.write("/chatter", chatter(i), log_time_ns=i)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(path.read_bytes()[:-300])
    monkeypatch.setattr(mcap_chunks, "_MAPPED_FROM", 1)
    with open_bag(path) as bag:
        assert [m.value for m in bag] == [f"hello {i}" for i in range(200)]
        assert bag.damage == []
    with open_bag(cut) as bag:
        assert [m.value for m in bag] == [f"hello {i}" for i in range(200)]


@pytest.mark.parametrize("compression", ["zstd", "none"])
def test_chunk_buffers_are_reused_only_when_no_value_views_them(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, compression: str
) -> None:
    """A file reuses its last chunk buffer for the next chunk once nothing views it: natural
    images kept by the caller (views on their chunks) keep their pixels, and a read that keeps
    nothing loads every chunk after the first into the same buffer."""
    from pyconnect.record import mcap_chunks

    path = write_images(tmp_path / "images.mcap", 30, (100, 100, 1), compression=compression,
                        chunk_size=50_000)  # fmt: skip
    with open_bag(path) as bag:
        kept = [item.value for item in bag]
    assert [(int(v.min()), int(v.max())) for v in kept] == [(i, i) for i in range(30)]

    made: list[int] = []
    take = mcap_chunks.ChunkBuffers.take

    def counting_take(self: mcap_chunks.ChunkBuffers, size: int) -> memoryview:
        before = id(self._spare)  # not the buffer: a reference would keep it from reuse
        view = take(self, size)
        if id(self._spare) != before:
            made.append(size)
        return view

    monkeypatch.setattr(mcap_chunks.ChunkBuffers, "take", counting_take)
    with open_bag(path) as bag:
        assert sum(1 for _ in bag) == 30
    assert len(made) == 1, made
