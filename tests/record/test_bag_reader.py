"""open_bag/bag_info on bags written here: layouts, storages, filters, and every error message."""

from __future__ import annotations

import datetime
import shutil
import sqlite3
import threading
from pathlib import Path

import numpy
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.serialization import serialize_message
from std_msgs.msg import String
from test_msgs.msg import BasicTypes

from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_reader import BagMessage, bag_info, open_bag
from pyconnect.record.mcap_recorder import McapRecorder


def chatter(i: int) -> bytes:
    return bytes(serialize_message(String(data=f"hello {i}")))


def write_bag(path: Path, *, count: int = 10, start: int = 1_000) -> Path:
    with McapRecorder(path) as recorder:
        recorder.add_topic("/chatter", "std_msgs/msg/String")
        recorder.add_topic("/basic", "test_msgs/msg/BasicTypes")
        recorder.add_topic("/silent", "std_msgs/msg/String")
        for i in range(count):
            recorder.write("/chatter", chatter(i), log_time_ns=start + 10 * i)
            basic = BasicTypes(int32_value=i, float64_value=i / 2)
            recorder.write(
                "/basic", bytes(serialize_message(basic)), log_time_ns=start + 10 * i + 5
            )
    return path


def write_db3(path: Path, *, schema: str = "foxy", count: int = 4) -> Path:
    """A sqlite3 bag with the tables of an old rosbag2 (``schema``: dashing or foxy)."""
    db = sqlite3.connect(path)
    qos = "" if schema == "dashing" else ", offered_qos_profiles TEXT NOT NULL"
    db.execute(
        "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, "
        f"serialization_format TEXT NOT NULL{qos})"
    )
    db.execute(
        "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, "
        "timestamp INTEGER NOT NULL, data BLOB NOT NULL)"
    )
    values = (1, "/chatter", "std_msgs/msg/String", "cdr") + (() if schema == "dashing" else ("",))
    db.execute(f"INSERT INTO topics VALUES ({','.join('?' * len(values))})", values)
    # Stored out of time order on purpose: reading sorts by time.
    for i in reversed(range(count)):
        db.execute("INSERT INTO messages VALUES (NULL, 1, ?, ?)", (100 + i, chatter(i)))
    db.commit()
    db.close()
    return path


def test_round_trip_through_a_recorded_bag(tmp_path: Path) -> None:
    write_bag(tmp_path / "bag")
    with open_bag(tmp_path / "bag") as bag:
        messages = list(bag)
    assert len(messages) == 20
    topic, stamp, value = messages[0]
    assert (topic, stamp, value) == ("/chatter", 1_000, "hello 0")
    assert messages[0].msg_type == "std_msgs/msg/String"
    assert [m.log_time_ns for m in messages] == sorted(m.log_time_ns for m in messages)
    assert [m.value["int32_value"] for m in messages if m.topic == "/basic"] == list(range(10))
    assert bag.errors == []


def test_bag_message_unpacks_as_three() -> None:
    message = BagMessage("/t", 5, {"a": 1}, "pkg/msg/T")
    topic, stamp, value = message
    assert (topic, stamp, value) == ("/t", 5, {"a": 1})
    assert (
        repr(message)
        == "BagMessage(topic='/t', log_time_ns=5, msg_type='pkg/msg/T', value={'a': 1})"
    )


def test_topic_and_time_filters(tmp_path: Path) -> None:
    write_bag(tmp_path / "bag")
    with open_bag(tmp_path / "bag", topics=["/chatter"], start_ns=1_020, end_ns=1_050) as bag:
        assert [(m.topic, m.log_time_ns, m.value) for m in bag] == [
            ("/chatter", 1_020, "hello 2"),
            ("/chatter", 1_030, "hello 3"),
            ("/chatter", 1_040, "hello 4"),
        ]
    with open_bag(tmp_path / "bag", natural=False, topics="/chatter", end_ns=1_001) as bag:
        assert [m.value for m in bag] == [{"data": "hello 0"}]


@pytest.mark.parametrize("storage", ["mcap", "db3"])
@pytest.mark.parametrize(
    ("option", "value", "type_name"),
    [
        ("start_ns", "1020", "str"),
        ("end_ns", 1050.0, "float"),
        ("start_ns", True, "bool"),
        ("end_ns", datetime.datetime(2024, 5, 3, 13, 0), "naive datetime"),
        ("start_ns", datetime.date(2024, 5, 3), "date"),
    ],
)
def test_time_bounds_of_another_type_are_refused_when_opened(
    tmp_path: Path, storage: str, option: str, value: object, type_name: str
) -> None:
    # Unchecked, a .db3 file compared them with its integers (nothing or everything selected)
    # and an MCAP file raised mid-read.
    path = write_bag(tmp_path / "bag") if storage == "mcap" else write_db3(tmp_path / "bag.db3")
    with pytest.raises(
        TypeError, match=f"{option}: expected int nanoseconds.*, got (a )?{type_name} "
    ):
        open_bag(path, **{option: value}).close()  # type: ignore[arg-type]


@pytest.mark.parametrize("registry", ["default", object()])
def test_a_registry_of_another_type_is_refused_when_opened(
    tmp_path: Path, registry: object
) -> None:
    # Unchecked, every message of the read failed alone with an AttributeError.
    path = write_bag(tmp_path / "bag")
    with pytest.raises(TypeError) as raised:
        open_bag(path, registry=registry).close()  # type: ignore[arg-type]
    assert str(raised.value) == (
        "registry: expected a pyconnect.codecs.Registry (or None for the default registry), "
        f"got {type(registry).__name__} ({registry!r:.80})"
    )


def test_time_bounds_take_aware_datetimes_and_numpy_integers(tmp_path: Path) -> None:
    write_bag(tmp_path / "bag")
    plus_two = datetime.timezone(datetime.timedelta(hours=2))
    # 1 µs after the epoch, written in another zone: exactly 1_000 ns.
    start = datetime.datetime(1970, 1, 1, 2, 0, 0, 1, tzinfo=plus_two)
    with open_bag(
        tmp_path / "bag", topics=["/chatter"], start_ns=start, end_ns=numpy.int64(1_030)
    ) as bag:
        assert (bag.start_ns, bag.end_ns) == (1_000, 1_030)
        assert type(bag.end_ns) is int
        assert [m.log_time_ns for m in bag] == [1_000, 1_010, 1_020]
    moment = datetime.datetime(2024, 5, 3, 13, 0, 0, 123456, tzinfo=datetime.timezone.utc)
    with open_bag(tmp_path / "bag", start_ns=moment) as bag:
        assert bag.start_ns == 1_714_741_200_123_456_000
        assert list(bag) == []


@pytest.mark.parametrize("storage", ["mcap", "db3"])
def test_time_bounds_beyond_int64_are_clamped(tmp_path: Path, storage: str) -> None:
    path = write_bag(tmp_path / "bag") if storage == "mcap" else write_db3(tmp_path / "bag.db3")
    with open_bag(path, start_ns=-(2**70), end_ns=2**70) as bag:
        assert (bag.start_ns, bag.end_ns) == (-(2**63), 2**63 - 1)
        assert len(list(bag)) == (20 if storage == "mcap" else 4)  # no OverflowError
    with open_bag(path, start_ns=2**64) as bag:
        assert list(bag) == []


def test_one_db3_reader_read_in_two_threads_gives_each_every_message(tmp_path: Path) -> None:
    # A .db3 file's one sqlite3 connection serves both reads (SQLite serialises them).
    path = write_db3(tmp_path / "bag.db3", count=3000)
    got: dict[int, list[int]] = {}
    with open_bag(path, raw=True) as bag:

        def read(number: int) -> None:
            got[number] = [m.log_time_ns for m in bag]

        threads = [threading.Thread(target=read, args=(k,)) for k in range(2)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        everything = list(range(100, 3100))
        assert got == {0: everything, 1: everything}
        assert bag.damage == []


def test_bag_info(tmp_path: Path) -> None:
    write_bag(tmp_path / "bag")
    info = bag_info(tmp_path / "bag" / "metadata.yaml")
    assert info.storage == "mcap"
    assert info.files == (tmp_path / "bag" / "bag_0.mcap",)
    assert [(t.name, t.msg_type, t.message_count) for t in info.topics] == [
        ("/basic", "test_msgs/msg/BasicTypes", 10),
        ("/chatter", "std_msgs/msg/String", 10),
        ("/silent", "std_msgs/msg/String", 0),
    ]
    assert (info.start_ns, info.end_ns, info.duration_ns, info.message_count) == (
        1_000,
        1_095,
        95,
        20,
    )


def test_split_bag_without_metadata(tmp_path: Path) -> None:
    # Files sort naturally: part_10 after part_9.
    bag = tmp_path / "split"
    bag.mkdir()
    for part in (0, 9, 10):
        write_bag(tmp_path / f"p{part}.mcap", count=2, start=1_000 * (part + 1))
        shutil.move(tmp_path / f"p{part}.mcap", bag / f"part_{part}.mcap")
    info = bag_info(bag)
    assert [p.name for p in info.files] == ["part_0.mcap", "part_9.mcap", "part_10.mcap"]
    with open_bag(bag, topics=["/chatter"]) as reader:
        assert [m.log_time_ns for m in reader] == [1_000, 1_010, 10_000, 10_010, 11_000, 11_010]


def test_old_sqlite_schemas_are_read_only(tmp_path: Path) -> None:
    for schema in ("dashing", "foxy"):
        path = write_db3(tmp_path / f"{schema}.db3", schema=schema)
        before = sorted(p.name for p in tmp_path.iterdir())
        with open_bag(path) as bag:
            assert [(m.log_time_ns, m.value) for m in bag] == [
                (100 + i, f"hello {i}") for i in range(4)
            ]
        assert sorted(p.name for p in tmp_path.iterdir()) == before
        assert bag_info(path).storage == "sqlite3"


def test_unfinished_mcap_is_read_without_its_summary(tmp_path: Path) -> None:
    write_bag(tmp_path / "bag.mcap")
    data = (tmp_path / "bag.mcap").read_bytes()
    # Cut the file inside its summary section, as a crash while recording would.
    (tmp_path / "cut.mcap").write_bytes(data[: len(data) - 200])
    with open_bag(tmp_path / "cut.mcap", topics=["/chatter"]) as bag:
        assert [m.value for m in bag] == [f"hello {i}" for i in range(10)]
    assert {t.name: t.message_count for t in bag_info(tmp_path / "cut.mcap").topics} == {
        "/basic": 10,
        "/chatter": 10,
        "/silent": 0,
    }


def test_errors(tmp_path: Path) -> None:
    write_bag(tmp_path / "bag")
    cases = {
        tmp_path / "missing": f"{tmp_path / 'missing'}: no such bag file or directory",
        tmp_path / "empty": f"{tmp_path / 'empty'}: no metadata.yaml and no .mcap or .db3 files",
        tmp_path / "text.mcap": f"{tmp_path / 'text.mcap'}: neither an MCAP nor a sqlite3 bag file",
    }
    (tmp_path / "empty").mkdir()
    (tmp_path / "text.mcap").write_text("hello")
    for path, message in cases.items():
        with pytest.raises(BagError) as caught:
            open_bag(path)
        assert str(caught.value) == message
    with pytest.raises(BagError) as caught:
        open_bag(tmp_path / "bag", topics=["/nope"])
    assert str(caught.value) == (
        f"{tmp_path / 'bag'}: no topic /nope in this bag (topics: /basic, /chatter, /silent)"
    )
    with pytest.raises(ValueError, match=r"^on_error: expected 'report' or 'raise', got 'skip'$"):
        open_bag(tmp_path / "bag", on_error="skip")  # type: ignore[arg-type]


def test_metadata_errors(tmp_path: Path) -> None:
    write_bag(tmp_path / "bag")
    metadata = tmp_path / "bag" / "metadata.yaml"
    text = metadata.read_text()
    metadata.write_text(text.replace("bag_0.mcap", "gone_0.mcap"))
    with pytest.raises(BagError) as caught:
        open_bag(tmp_path / "bag")
    assert str(caught.value) == (
        f"{tmp_path / 'bag'}: metadata.yaml lists 'gone_0.mcap', which is not in the bag"
    )
    metadata.write_text(text.replace("compression_mode: ''", "compression_mode: FILE"))
    with pytest.raises(BagError) as caught:
        open_bag(tmp_path / "bag")
    # Compressed whole (pyconnect.record.file_compression) in no format: not a bag to guess at.
    assert str(caught.value) == (
        f"{metadata}: compression_format: expected 'zstd' for compression_mode 'FILE', got ''"
    )
    metadata.write_text("just: text\n")
    with pytest.raises(BagError) as caught:
        open_bag(tmp_path / "bag")
    assert str(caught.value) == (
        f"{metadata}: not a rosbag2 metadata file (KeyError: 'rosbag2_bagfile_information')"
    )


def test_undecodable_definition_is_reported_per_message(tmp_path: Path) -> None:
    with McapRecorder(tmp_path / "bag.mcap") as recorder:
        recorder.add_topic("/odd", "my_pkg/msg/Odd", definition="not a definition at all !!!")
        recorder.add_topic("/chatter", "std_msgs/msg/String")
        for i in range(3):
            recorder.write("/odd", b"\x00\x01\x00\x00", log_time_ns=i)
            recorder.write("/chatter", chatter(i), log_time_ns=i)
    with open_bag(tmp_path / "bag.mcap") as bag:
        assert [m.value for m in bag] == ["hello 0", "hello 1", "hello 2"]
    assert [(p.topic, p.index) for p in bag.errors] == [("/odd", 0), ("/odd", 1), ("/odd", 2)]
    assert bag.errors[0].reason.startswith("cannot build a decoder for my_pkg/msg/Odd: ")


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_every_chunk_compression_reads_back(tmp_path: Path, compression: str) -> None:
    with McapRecorder(tmp_path / "bag.mcap", compression=compression, chunk_size=256) as recorder:
        recorder.add_topic("/chatter", "std_msgs/msg/String")
        for i in range(50):
            recorder.write("/chatter", chatter(i), log_time_ns=i)
    with open_bag(tmp_path / "bag.mcap") as bag:
        assert [m.value for m in bag] == [f"hello {i}" for i in range(50)]


@settings(max_examples=40, deadline=None)
@given(
    stamps=st.lists(st.integers(0, 10_000), min_size=0, max_size=60),
    chunk_size=st.sampled_from([64, 300, 1 << 20]),
    window=st.tuples(st.integers(0, 10_000), st.integers(0, 10_000)),
)
def test_written_messages_come_back_in_time_order(
    tmp_path_factory: pytest.TempPathFactory,
    stamps: list[int],
    chunk_size: int,
    window: tuple[int, int],
) -> None:
    # Writes out of time order make chunks whose time ranges overlap: reading merges them.
    path = tmp_path_factory.mktemp("bags") / "bag.mcap"
    with McapRecorder(path, chunk_size=chunk_size) as recorder:
        recorder.add_topic("/chatter", "std_msgs/msg/String")
        for i, stamp in enumerate(stamps):
            recorder.write("/chatter", chatter(i), log_time_ns=stamp)
    written = [(stamp, f"hello {i}") for i, stamp in enumerate(stamps)]
    with open_bag(path) as bag:
        read = [(m.log_time_ns, m.value) for m in bag]
    assert [stamp for stamp, _ in read] == sorted(stamps)
    assert sorted(read) == sorted(written)
    start, end = min(window), max(window)
    with open_bag(path, start_ns=start, end_ns=end) as bag:
        assert sorted((m.log_time_ns, m.value) for m in bag) == sorted(
            (stamp, value) for stamp, value in written if start <= stamp < end
        )


def test_reading_again_starts_afresh(tmp_path: Path) -> None:
    with McapRecorder(tmp_path / "bag.mcap") as recorder:
        recorder.add_topic("/chatter", "std_msgs/msg/String")
        recorder.write("/chatter", b"\x00\x01\x00\x00\xff\xff\xff\x7f", log_time_ns=1)
        recorder.write("/chatter", chatter(1), log_time_ns=2)
    with open_bag(tmp_path / "bag.mcap") as bag:
        first = [m.value for m in bag]
        assert [(p.topic, p.index) for p in bag.errors] == [("/chatter", 0)]
        second = [m.value for m in bag]
        assert [(p.topic, p.index) for p in bag.errors] == [("/chatter", 0)]
    assert first == second == ["hello 1"]


# rosbag2 writes ros2idl schemas as blocks, each under a separator and an "IDL: " line.
THING_IDL = (
    "=" * 80
    + "\nIDL: my_pkg/msg/Thing\n"
    + """module my_pkg {
  module msg {
    struct Thing {
      double x;
      string name;
      sequence<int32> counts;
    };
  };
};
"""
)


def test_ros2idl_schema_of_a_type_not_installed(tmp_path: Path) -> None:
    from mcap.writer import Writer

    from pyconnect.codecs import wire

    codec = wire.wire_codec("my_pkg/msg/Thing", definition=THING_IDL, encoding="ros2idl")
    with (tmp_path / "idl.mcap").open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2", library="test")
        schema = writer.register_schema(
            name="my_pkg/msg/Thing", encoding="ros2idl", data=THING_IDL.encode()
        )
        channel = writer.register_channel(topic="/thing", message_encoding="cdr", schema_id=schema)
        for i in range(3):
            data = codec.from_dict({"x": i / 2, "name": f"t{i}", "counts": list(range(i))})
            writer.add_message(channel, log_time=i, data=data, publish_time=i)
        writer.finish()
    with open_bag(tmp_path / "idl.mcap") as bag:
        values = [m.value for m in bag]
    assert bag.errors == []
    assert [(v["x"], v["name"], list(v["counts"])) for v in values] == [
        (0.0, "t0", []),
        (0.5, "t1", [0]),
        (1.0, "t2", [0, 1]),
    ]


def write_two_types(bag: Path) -> Path:
    """Three MCAP channels of /chatter, String then Int32 then String, a message on each."""
    from mcap.writer import Writer

    with bag.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2", library="test")
        string = writer.register_schema("std_msgs/msg/String", "ros2msg", b"string data")
        int32 = writer.register_schema("std_msgs/msg/Int32", "ros2msg", b"int32 data")
        for time, schema in enumerate([string, int32, string], 1):
            channel = writer.register_channel("/chatter", "cdr", schema)
            data = serialize_message(String(data="a")) if schema == string else b"\0\1\0\0\7\0\0\0"
            writer.add_message(channel, log_time=time, data=data, publish_time=time)
        writer.finish()
    return bag


def test_topic_codecs_gives_each_type_of_a_topic_in_one_bag(tmp_path: Path) -> None:
    """Two MCAP channels of /chatter, String then Int32, then a third String one: one codec per
    type, the same bag's path for each (the first type alone hid the second from tables)."""
    bag = write_two_types(tmp_path / "two_types.mcap")
    with open_bag(bag) as reader:
        codecs = reader.topic_codecs("/chatter")
        assert [(path, codec.msg_type) for path, codec in codecs] == [
            (bag, "std_msgs/msg/String"),
            (bag, "std_msgs/msg/Int32"),
        ]
        assert reader.topic_codec("/chatter") is codecs[0][1]


def test_with_codecs_gives_each_message_the_codec_of_its_connection(tmp_path: Path) -> None:
    """A topic's messages decoded with two codecs come each with its own (``topic_codec`` is the
    first connection's only); reading raw, with none."""
    bag = write_two_types(tmp_path / "two_types.mcap")
    with open_bag(bag, natural=False) as reader:
        read = list(reader.with_codecs())
        assert [m.value for m in reader] == [m.value for m, _codec in read]
        codecs = [codec for _path, codec in reader.topic_codecs("/chatter")]
    assert [m.value for m, _codec in read] == [{"data": "a"}, {"data": 7}, {"data": "a"}]
    assert [codec for _m, codec in read] == [codecs[0], codecs[1], codecs[0]]
    assert all(codec.from_dict(m.value) for m, codec in read)
    with open_bag(bag, raw=True) as reader:
        assert [codec for _m, codec in reader.with_codecs()] == [None] * 3


def test_tables_of_a_reader_keep_its_types(tmp_path: Path) -> None:
    """``open_bag(types=)`` then ``to_arrow``: the table read every type of the topic again
    (a topic of two types is refused as one table, while the reader had chosen one)."""
    bag = write_two_types(tmp_path / "two_types.mcap")
    with open_bag(bag, types=["std_msgs/msg/Int32"]) as reader:
        table = reader.to_arrow("/chatter")
    assert table.column("data").to_pylist() == [7]
    with open_bag(bag, types=["std_msgs/msg/String"]) as reader:
        assert reader.to_pandas("/chatter")["data"].tolist() == ["a", "a"]
