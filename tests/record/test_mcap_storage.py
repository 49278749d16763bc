"""Reading MCAP files (``mcap_storage``): one reader iterated in several threads at once,
messages of equal log time in chunks that overlap in time, and summaries that do not repeat the
channels and schemas."""

from __future__ import annotations

import random
import threading
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader
from mcap.records import Channel, Message
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, IndexType, Writer
from rclpy.serialization import serialize_message
from std_msgs.msg import Int64, String

from pyconnect.record import mcap_chunks
from pyconnect.record.bag_info import bag_info
from pyconnect.record.bag_reader import open_bag
from pyconnect.record.mcap_recorder import McapRecorder


def write_counts(path: Path, times: list[int], *, compression: str, chunk_size: int) -> Path:
    """Message ``i`` (an Int64 of value ``i``) at ``times[i]``, on /a (odd) and /b (even)."""
    with McapRecorder(path, compression=compression, chunk_size=chunk_size) as recorder:
        recorder.add_topic("/a", "std_msgs/msg/Int64")
        recorder.add_topic("/b", "std_msgs/msg/Int64")
        for i, stamp in enumerate(times):
            recorder.write_value("/a" if i % 2 else "/b", i, log_time_ns=stamp)
    return path


@pytest.mark.parametrize("compression", ["", "zstd"])
def test_one_reader_read_in_two_threads_gives_each_every_message(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, compression: str
) -> None:
    count = 600
    path = write_counts(
        tmp_path / "bag.mcap", list(range(count)), compression=compression, chunk_size=1000
    )
    # Both threads read a chunk's head before either reads its records: a file position
    # shared by the two reads is then wherever the other one left it.
    original = mcap_chunks.read_chunk_head
    meet = threading.Barrier(2, timeout=10)
    met: set[int] = set()

    def both_at_a_chunk(stream: Any, offset: int) -> Any:
        head = original(stream, offset)
        if threading.get_ident() not in met:
            met.add(threading.get_ident())
            meet.wait()
        return head

    got: dict[int, list[int]] = {}
    with open_bag(path) as bag:
        # Patched once the bag is open: the modules that import it by name are imported then.
        monkeypatch.setattr(mcap_chunks, "read_chunk_head", both_at_a_chunk)

        def read(number: int) -> None:
            got[number] = [message.value for message in bag]

        threads = [threading.Thread(target=read, args=(k,)) for k in range(2)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        assert got == {0: list(range(count)), 1: list(range(count))}
        assert bag.damage == []
        monkeypatch.undo()
        assert [message.value for message in bag] == list(range(count))
        assert bag.damage == []


@pytest.mark.parametrize(
    "options",
    [{}, {"start_ns": 10_000, "end_ns": 30_000}, {"topics": ["/a"]}],
    ids=["all", "window", "one topic"],
)
def test_equal_log_times_come_in_write_order_across_overlapping_chunks(
    tmp_path: Path, options: dict[str, Any]
) -> None:
    # Log times out of order and small chunks: the chunks overlap in time, and their start
    # times are not in file order, so each log time has messages in several of them.
    rng = random.Random(3)
    times = [rng.randrange(50) * 1000 for _ in range(2000)]
    path = write_counts(tmp_path / "ooo.mcap", times, compression="zstd", chunk_size=2000)
    with open_bag(path, **options) as bag:
        got = [(message.log_time_ns, message.value) for message in bag]
    start, end = options.get("start_ns", 0), options.get("end_ns", 10**9)
    odd_only = "topics" in options
    written = [
        (stamp, i)
        for i, stamp in enumerate(times)
        if start <= stamp < end and (i % 2 or not odd_only)
    ]
    assert got == sorted(written, key=lambda message: message[0])  # stable: write order


def test_equal_log_times_come_as_the_mcap_reader_gives_them(tmp_path: Path) -> None:
    rng = random.Random(5)
    times = [rng.randrange(20) for _ in range(1500)]
    path = write_counts(tmp_path / "ooo.mcap", times, compression="", chunk_size=1500)
    with path.open("rb") as stream:
        reader = make_reader(stream)
        chunks = reader.get_summary().chunk_indexes  # type: ignore[union-attr]
        expected = [
            (message.log_time, bytes(message.data))
            for _, _, message in reader.iter_messages(log_time_order=True)
        ]
    assert len(chunks) > 10
    with open_bag(path, raw=True) as bag:
        assert [(message.log_time_ns, message.value) for message in bag] == expected


@pytest.mark.parametrize(
    "options",
    [
        {"repeat_channels": False, "repeat_schemas": False},
        {"repeat_channels": False, "repeat_schemas": True},
        {"repeat_channels": True, "repeat_schemas": False},
        # no message indexes nor statistics: nothing names the channels the summary lacks
        {
            "repeat_channels": False,
            "repeat_schemas": False,
            "index_types": IndexType.CHUNK,
            "use_statistics": False,
        },
    ],
    ids=["neither", "schemas only", "channels only", "chunk index only"],
)
def test_a_summary_that_does_not_repeat_channels_reads_every_message(
    tmp_path: Path, options: dict[str, Any]
) -> None:
    # The spec lets a writer leave channels and schemas out of the summary: they are then in
    # the chunks only, which must be read for them rather than the file taken for empty.
    path = tmp_path / "norepeat.mcap"
    with path.open("wb") as stream:
        writer = Writer(stream, chunk_size=400, compression=CompressionType.ZSTD, **options)
        writer.start(profile="ros2", library="test")
        text = writer.register_schema("std_msgs/msg/String", "ros2msg", b"string data")
        number = writer.register_schema("std_msgs/msg/Int64", "ros2msg", b"int64 data")
        chatter = writer.register_channel("/chatter", "cdr", text)
        counts = writer.register_channel("/counts", "cdr", number)
        for i in range(60):
            stamp = 1_000 + (i * 7) % 45  # out of order: chunks overlap in time
            if i % 3:
                data = bytes(serialize_message(Int64(data=i)))
                writer.add_message(counts, log_time=stamp, data=data, publish_time=stamp)
            else:
                data = bytes(serialize_message(String(data=f"m{i}")))
                writer.add_message(chatter, log_time=stamp, data=data, publish_time=stamp)
        writer.finish()
    with path.open("rb") as stream:
        summary = make_reader(stream).get_summary()
        assert summary is not None and len(summary.chunk_indexes) > 3
        assert not (options["repeat_channels"] and options["repeat_schemas"])
        # mcap's seeking reader takes channels from the summary only: its stream reader, then.
        stream.seek(0)
        channels: dict[int, str] = {}
        written = []
        for record in StreamReader(stream).records:
            if isinstance(record, Channel):
                channels[record.id] = record.topic
            elif isinstance(record, Message):
                written.append((channels[record.channel_id], record.log_time, record.data))
    expected = sorted(written, key=lambda message: message[1])  # stable: equal times as written
    assert len(expected) == 60
    info = bag_info(path)
    assert {(t.name, t.msg_type, t.message_count) for t in info.topics} == {
        ("/chatter", "std_msgs/msg/String", 20),
        ("/counts", "std_msgs/msg/Int64", 40),
    }
    assert info.damage == ()
    with open_bag(path, raw=True) as bag:
        got = [(m.topic, m.log_time_ns, bytes(m.value)) for m in bag]
    assert got == expected
    with open_bag(path) as bag:
        values = [m.value for m in bag if m.topic == "/counts"]
    assert (bag.errors, bag.damage) == ([], [])
    assert sorted(values) == [i for i in range(60) if i % 3]
