"""Bag topics as Arrow, pandas and polars tables; Parquet export read back by DuckDB and polars."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import duckdb
import numpy as np
import polars as pl
import pyarrow as pa
import pytest
from geometry_msgs.msg import PoseWithCovarianceStamped, Twist, TwistStamped
from sensor_msgs.msg import Image
from test_msgs.msg import Arrays, BasicTypes, UnboundedSequences

from pyconnect.record import BagError, bag_info, open_bag
from pyconnect.record.mcap_recorder import McapRecorder
from pyconnect.record.parquet_export import export_parquet
from tests.conftest import require_sample_bags
from tests.record.bag_samples import BAGS
from tests.record.table_bags import stamp_of, write_bag

T0 = 1_700_000_000_000_000_000


def _basic(i: int) -> BasicTypes:
    return BasicTypes(
        bool_value=bool(i % 2),
        byte_value=bytes([i]),
        char_value=65 + i,
        float32_value=0.5 * i,
        float64_value=1.25 * i,
        int8_value=-100 + i,
        uint8_value=200 + i,
        int16_value=-3000 - i,
        uint16_value=60000 + i,
        int32_value=-(10**9) + i,
        uint32_value=4 * 10**9 + i,
        int64_value=-(10**18) - i,
        uint64_value=18 * 10**18 + i,
    )


def _pose(i: int) -> PoseWithCovarianceStamped:
    msg = PoseWithCovarianceStamped()
    msg.header.stamp.sec, msg.header.stamp.nanosec = stamp_of(T0 + i * 10_000_000)
    msg.header.frame_id = "map"
    msg.pose.pose.position.x = float(i)
    msg.pose.pose.orientation.w = 1.0
    msg.pose.covariance = [float(i * 100 + k) for k in range(36)]
    return msg


def _image(i: int) -> Image:
    msg = Image(height=2, width=3, encoding="rgb8", step=9)
    msg.header.frame_id = "cam"
    msg.data = bytes((i + k) % 256 for k in range(18))
    return msg


def _table(bag: Path, topic: str, how: str = "to_arrow") -> Any:
    with open_bag(bag) as reader:
        return getattr(reader, how)(topic)


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    messages = []
    for i in range(3):
        messages.append(("/basic", T0 + i, _basic(i)))
        messages.append(("/pose", T0 + i, _pose(i)))
        messages.append(("/camera/image_raw", T0 + i, _image(i)))
        arrays = Arrays()
        arrays.int8_values = [-1, 0, i]
        arrays.string_values = ["a", "b", str(i)]
        messages.append(("/arrays", T0 + i, arrays))
        messages.append(("/seqs", T0 + i, UnboundedSequences(float32_values=[0.5] * i)))
    return write_bag(tmp_path_factory.mktemp("tables") / "bag", messages)


def test_scalars_keep_their_ros_types(bag: Path) -> None:
    table = _table(bag, "/basic", "to_arrow")
    types = {field.name: field.type for field in table.schema}
    assert types == {
        "log_time_ns": pa.int64(),
        "bool_value": pa.bool_(),
        "byte_value": pa.uint8(),
        "char_value": pa.uint8(),
        "float32_value": pa.float32(),
        "float64_value": pa.float64(),
        "int8_value": pa.int8(),
        "uint8_value": pa.uint8(),
        "int16_value": pa.int16(),
        "uint16_value": pa.uint16(),
        "int32_value": pa.int32(),
        "uint32_value": pa.uint32(),
        "int64_value": pa.int64(),
        "uint64_value": pa.uint64(),
    }
    rows = table.to_pylist()
    assert [row["log_time_ns"] for row in rows] == [T0, T0 + 1, T0 + 2]
    assert rows[2]["int8_value"] == -98
    assert rows[2]["uint64_value"] == 18 * 10**18 + 2
    assert rows[1]["byte_value"] == 1
    assert table.schema.metadata == {b"topic": b"/basic", b"msg_type": b"test_msgs/msg/BasicTypes"}


def test_nested_fields_flatten_and_arrays_stay_one_column(bag: Path) -> None:
    table = _table(bag, "/pose", "to_arrow")
    assert table.schema.names == [
        "log_time_ns",
        "header.stamp.sec",
        "header.stamp.nanosec",
        "header.frame_id",
        "pose.pose.position.x",
        "pose.pose.position.y",
        "pose.pose.position.z",
        "pose.pose.orientation.x",
        "pose.pose.orientation.y",
        "pose.pose.orientation.z",
        "pose.pose.orientation.w",
        "pose.covariance",
    ]
    assert table.schema.field("header.stamp.sec").type == pa.int32()
    assert table.schema.field("header.stamp.nanosec").type == pa.uint32()
    assert table.schema.field("pose.covariance").type == pa.list_(pa.float64(), 36)
    assert table.column("pose.pose.position.x").to_pylist() == [0.0, 1.0, 2.0]
    covariance = table.column("pose.covariance").combine_chunks()
    tensor = covariance.flatten().to_numpy().reshape(len(covariance), 36)
    assert tensor[2].tolist() == [float(200 + k) for k in range(36)]
    sec, nanosec = stamp_of(T0 + 20_000_000)
    assert table.column("header.stamp.sec")[2].as_py() == sec
    assert table.column("header.stamp.nanosec")[2].as_py() == nanosec


def test_images_are_binary_data_beside_their_shape_and_encoding(bag: Path) -> None:
    table = _table(bag, "/camera/image_raw", "to_arrow")
    assert table.schema.field("data").type == pa.binary()
    row = table.to_pylist()[1]
    assert (row["height"], row["width"], row["step"], row["encoding"]) == (2, 3, 9, "rgb8")
    pixels = np.frombuffer(row["data"], np.uint8).reshape(row["height"], row["width"], 3)
    assert pixels[0, 0].tolist() == [1, 2, 3]


def test_fixed_arrays_sequences_and_strings(bag: Path) -> None:
    arrays = _table(bag, "/arrays", "to_arrow")
    assert arrays.schema.field("int8_values").type == pa.list_(pa.int8(), 3)
    assert arrays.schema.field("byte_values").type == pa.binary(3)
    assert arrays.schema.field("bool_values").type == pa.list_(pa.bool_(), 3)
    assert arrays.schema.field("string_values").type == pa.list_(pa.string(), 3)
    assert arrays.column("int8_values").to_pylist()[2] == [-1, 0, 2]
    assert arrays.column("string_values").to_pylist()[1] == ["a", "b", "1"]
    nested = arrays.schema.field("basic_types_values").type
    assert nested.value_type.field("int8_value").type == pa.int8()
    seqs = _table(bag, "/seqs", "to_arrow")
    assert seqs.schema.field("float32_values").type == pa.list_(pa.float32())
    assert seqs.column("float32_values").to_pylist() == [[], [0.5], [0.5, 0.5]]


def test_pandas_and_polars_have_the_same_columns_and_types(bag: Path) -> None:
    with open_bag(bag) as reader:
        frame = reader.to_pandas("/basic")
        polars_frame = reader.to_polars("/pose")
        arrow_names = reader.to_arrow("/basic").schema.names
    assert list(frame.columns) == arrow_names
    assert str(frame["int8_value"].dtype) == "int8"
    assert str(frame["uint16_value"].dtype) == "uint16"
    assert frame["int8_value"].tolist() == [-100, -99, -98]
    assert polars_frame.schema["header.stamp.sec"] == pl.Int32
    assert polars_frame.schema["pose.covariance"] == pl.Array(pl.Float64, 36)
    assert polars_frame["pose.pose.position.x"].to_list() == [0.0, 1.0, 2.0]


def test_an_unknown_topic_is_an_error_naming_the_topics(bag: Path) -> None:
    with pytest.raises(BagError) as raised:
        _table(bag, "/nope", "to_arrow")
    assert str(raised.value) == (
        f"{bag}: no topic /nope in this bag (topics: /arrays, /basic, /camera/image_raw, /pose, "
        "/seqs)"
    )


def test_parquet_export_is_read_by_duckdb_and_polars(bag: Path, tmp_path: Path) -> None:
    result = export_parquet(bag, tmp_path / "out")
    assert sorted(result.files) == ["/arrays", "/basic", "/camera/image_raw", "/pose", "/seqs"]
    assert result.errors == []
    pose_file = tmp_path / "out" / "pose.parquet"
    assert result.files["/pose"] == (pose_file, 3)
    rows = duckdb.sql(
        f'SELECT "pose.pose.position.x", "header.stamp.sec" FROM \'{pose_file}\' ORDER BY 1'
    ).fetchall()
    assert rows == [(float(i), stamp_of(T0 + i * 10_000_000)[0]) for i in range(3)]
    basic = pl.read_parquet(tmp_path / "out" / "basic.parquet")
    assert basic.schema["int8_value"] == pl.Int8
    assert basic["int8_value"].to_list() == [-100, -99, -98]
    image = pl.read_parquet(tmp_path / "out" / "camera__image_raw.parquet")
    assert image["data"].dtype == pl.Binary


def test_parquet_export_of_one_topic(bag: Path, tmp_path: Path) -> None:
    result = export_parquet(bag, tmp_path, topics=["/basic"])
    assert list(result.files) == ["/basic"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["basic.parquet"]


def test_a_second_parquet_export_needs_force(bag: Path, tmp_path: Path) -> None:
    export_parquet(bag, tmp_path, topics=["/basic"])
    written = (tmp_path / "basic.parquet").stat().st_mtime_ns
    with pytest.raises(BagError) as refused:
        export_parquet(bag, tmp_path, topics=["/basic"])
    assert str(refused.value) == (
        f"{tmp_path}: already holds an export (basic.parquet); "
        "use force=True (--force) to overwrite it"
    )
    assert (tmp_path / "basic.parquet").stat().st_mtime_ns == written
    assert list(export_parquet(bag, tmp_path, topics=["/basic"], force=True).files) == ["/basic"]


# Every shared bag is read in tables by tests/record/test_tables_dask.py (`make scale`).
SHARED = ["rosbags_rs/test_bag_mcap", "robot_localization_converted/test1_ros2_mcap_zstd"]


@pytest.mark.parametrize("name", SHARED)
def test_every_shared_topic_tabulates_every_decodable_message(name: str) -> None:
    path = BAGS / name
    require_sample_bags(path, path.exists())
    with open_bag(path, natural=False) as reader:  # tables hold lossless dicts
        counts: dict[str, int] = {}
        for message in reader:
            counts[message.topic] = counts.get(message.topic, 0) + 1
        for topic in bag_info(path).topics:
            table = reader.to_arrow(topic.name)
            assert table.num_rows == counts.get(topic.name, 0), topic.name


# -- columns follow the definition the values are decoded with ------------------------------------
TALKER = BAGS / "ros2_rosbag2_jazzy/rosbag2_py/test/resources/sqlite3/talker"
# A stored definition of std_msgs/String with a field the installed type lacks (no type hash:
# the reader may give way to the installed type when the text does not fit the bytes).
TWO_STRINGS = "string data\nstring extra\n"


def _cdr_strings(*texts: str) -> bytes:
    """Little-endian CDR of consecutive string fields."""
    out = bytearray(b"\x00\x01\x00\x00")
    for text in texts:
        out += -len(out[4:]) % 4 * b"\x00"
        raw = text.encode() + b"\x00"
        out += len(raw).to_bytes(4, "little") + raw
    return bytes(out)


def _stored_strings_bag(
    path: Path, messages: list[bytes], definition: str = TWO_STRINGS, start_ns: int = 1_000
) -> Path:
    with McapRecorder(path) as recorder:
        recorder.add_topic("/s", "std_msgs/msg/String", definition=definition)
        for i, data in enumerate(messages):
            recorder.write("/s", data, log_time_ns=start_ns + i)
    return path


def test_columns_follow_the_installed_type_when_the_stored_definition_does_not_fit(
    tmp_path: Path,
) -> None:
    bag = _stored_strings_bag(tmp_path / "bag", [_cdr_strings("a"), _cdr_strings("b")])
    with open_bag(bag, natural=False) as reader:
        values = [m.value for m in reader]
        table = reader.to_arrow("/s")
    assert values == [{"data": "a"}, {"data": "b"}]
    assert table.column_names == ["log_time_ns", "data"]
    assert table.column("data").to_pylist() == ["a", "b"]


def test_values_of_two_definitions_in_one_topic_are_an_error(tmp_path: Path) -> None:
    # The stored text fits the first message, only the installed type fits the next three: the
    # third in a row gives the topic to it (the two before stay errors, as a damaged one would).
    later = [_cdr_strings(text) for text in "bcd"]
    bag = _stored_strings_bag(tmp_path / "bag", [_cdr_strings("a", "x"), *later])
    with open_bag(bag, natural=False) as reader:
        assert [m.value for m in reader] == [{"data": "a", "extra": "x"}, {"data": "d"}]
        assert [problem.index for problem in reader.errors] == [1, 2]
        with pytest.raises(BagError) as raised:
            reader.to_arrow("/s")
    assert str(raised.value) == (
        f"{bag}: /s: the first 1 message(s) decode with the definition of std_msgs/msg/String "
        "stored in the bag, later ones only with the installed type; one table cannot hold "
        "both (read them with open_bag)"
    )


def test_rosout_of_a_wrong_stored_definition_keeps_every_field(tmp_path: Path) -> None:
    # The fixture stores `uint8 level` for rcl_interfaces/Log: its bytes are the installed Log.
    require_sample_bags(TALKER, TALKER.exists())
    with open_bag(TALKER, topics=["/rosout"], natural=False) as reader:
        first = next(iter(reader)).value
        table = reader.to_arrow("/rosout")
    assert table.column_names == [
        "log_time_ns", "stamp.sec", "stamp.nanosec", "level", "name", "msg", "file", "function",
        "line",
    ]  # fmt: skip
    assert sorted(first) == ["file", "function", "level", "line", "msg", "name", "stamp"]
    export_parquet(TALKER, tmp_path / "out", topics=["/rosout"])
    exported = pl.read_parquet(next((tmp_path / "out").rglob("*.parquet")))
    assert exported.columns == table.column_names


# -- merged bags that store different definitions of a topic's type -------------------------------
def _two_definition_bags(tmp_path: Path) -> list[Path]:
    """The installed std_msgs/String (one field), then a later bag storing TWO_STRINGS."""
    one = _stored_strings_bag(
        tmp_path / "one", [_cdr_strings("a"), _cdr_strings("b")], definition="string data\n"
    )
    two = _stored_strings_bag(tmp_path / "two", [_cdr_strings("c", "x")], start_ns=2_000)
    return [one, two]


@pytest.mark.parametrize("order", [1, -1])
def test_merged_bags_give_the_union_of_their_definitions_columns(
    tmp_path: Path, order: int
) -> None:
    bags = _two_definition_bags(tmp_path)[::order]
    with open_bag(bags, natural=False) as reader:
        values = [m.value for m in reader]
        table = reader.to_arrow("/s")
        frame = reader.to_polars("/s")
        errors = reader.errors
    assert values == [{"data": "a"}, {"data": "b"}, {"data": "c", "extra": "x"}]
    assert table.column_names == ["log_time_ns", "data", "extra"]
    assert table.column("data").to_pylist() == ["a", "b", "c"]
    assert table.column("extra").to_pylist() == [None, None, "x"]
    assert frame.columns == table.column_names
    assert errors == []


def _twist_bags(tmp_path: Path) -> list[Path]:
    """/cmd_vel as geometry_msgs/Twist in one bag, as TwistStamped in a later one (Jazzy's
    migration): two types, not two definitions of one."""
    twist = Twist()
    twist.linear.x = 1.0
    stamped = TwistStamped()
    stamped.header.frame_id = "base"
    stamped.twist.linear.x = 2.0
    old = write_bag(tmp_path / "old_robot", [("/cmd_vel", 1_000, twist)])
    new = write_bag(tmp_path / "new_robot", [("/cmd_vel", 2_000, stamped)])
    return [old, new]


def test_merged_bags_of_two_types_of_a_topic_are_an_error(tmp_path: Path) -> None:
    old, new = _twist_bags(tmp_path)
    with open_bag([old, new]) as reader:
        assert len(list(reader)) == 2  # read as messages, each bag with its own type
        with pytest.raises(BagError) as raised:
            reader.to_arrow("/cmd_vel")
    assert str(raised.value) == (
        f"{new}: /cmd_vel: type geometry_msgs/msg/TwistStamped in this bag, "
        f"geometry_msgs/msg/Twist in {old}; one table cannot hold both types (read them with "
        "open_bag, or each bag on its own)"
    )


def test_a_later_bags_new_leading_field_goes_after_the_merged_columns(tmp_path: Path) -> None:
    one = _stored_strings_bag(tmp_path / "one", [_cdr_strings("a")], definition="string data\n")
    two = _stored_strings_bag(
        tmp_path / "two", [_cdr_strings("h", "b")], definition="string head\nstring data\n",
        start_ns=2_000,
    )  # fmt: skip
    with open_bag([one, two], natural=False) as reader:
        table = reader.to_arrow("/s")
    assert table.column_names == ["log_time_ns", "data", "head"]
    assert table.column("head").to_pylist() == [None, "h"]


def test_merged_bags_whose_field_types_differ_are_an_error(tmp_path: Path) -> None:
    one, _two = _two_definition_bags(tmp_path)
    number = _stored_strings_bag(
        tmp_path / "number", [b"\x00\x01\x00\x00" + (7).to_bytes(4, "little")],
        definition="int32 data\n", start_ns=3_000,
    )  # fmt: skip
    with open_bag([one, number], natural=False) as reader:
        assert [m.value for m in reader] == [{"data": "a"}, {"data": "b"}, {"data": 7}]
        with pytest.raises(BagError) as raised:
            reader.to_pandas("/s")
    assert str(raised.value) == (
        f"{number}: /s: field data is int32 in the definition of std_msgs/msg/String this bag is "
        f"read with, string in that of {one}; one table cannot hold both (read them with "
        "open_bag)"
    )


# -- one bag holding a topic on two channels (MCAP files of other tools) --------------------------
def _two_channel_bag(path: Path, channels: list[tuple[str, str, bytes]]) -> Path:
    """An MCAP file with ``channels`` (type, stored definition, one message's CDR) all on /s,
    one message each, in that order."""
    from mcap.writer import Writer

    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2", library="test")
        for time, (msg_type, definition, data) in enumerate(channels, 1):
            schema = writer.register_schema(msg_type, "ros2msg", definition.encode())
            channel = writer.register_channel("/s", "cdr", schema)
            writer.add_message(channel, log_time=time, data=data, publish_time=time)
        writer.finish()
    return path


_INT32_SEVEN = b"\x00\x01\x00\x00" + (7).to_bytes(4, "little")


def test_a_topic_of_two_types_in_one_bag_is_an_error(tmp_path: Path) -> None:
    bag = _two_channel_bag(
        tmp_path / "two_types.mcap",
        [("std_msgs/msg/String", "string data\n", _cdr_strings("a")),
         ("std_msgs/msg/Int32", "int32 data\n", _INT32_SEVEN)],
    )  # fmt: skip
    with open_bag(bag, natural=False) as reader:
        assert [m.value for m in reader] == [{"data": "a"}, {"data": 7}]
        # The second type was never seen: pyarrow failed on its first int in a string column.
        with pytest.raises(BagError) as raised:
            reader.to_pandas("/s")
    assert str(raised.value) == (
        f"{bag}: /s: two types in this bag, std_msgs/msg/String and std_msgs/msg/Int32; "
        "one table cannot hold both types (read them with open_bag)"
    )


def test_two_definitions_of_a_type_in_one_bag_whose_field_types_differ_are_an_error(
    tmp_path: Path,
) -> None:
    bag = _two_channel_bag(
        tmp_path / "two_definitions.mcap",
        [("std_msgs/msg/String", "string data\n", _cdr_strings("a")),
         ("std_msgs/msg/String", "int32 data\n", _INT32_SEVEN)],
    )  # fmt: skip
    with open_bag(bag, natural=False) as reader, pytest.raises(BagError) as raised:
        reader.to_arrow("/s")
    assert str(raised.value) == (
        f"{bag}: /s: field data is string in one definition of std_msgs/msg/String this bag "
        "stores, int32 in another; one table cannot hold both (read them with open_bag)"
    )


def test_two_channels_of_one_topic_in_one_bag_give_the_union_of_their_columns(
    tmp_path: Path,
) -> None:
    bag = _two_channel_bag(
        tmp_path / "two_channels.mcap",
        [("std_msgs/msg/String", "string data\n", _cdr_strings("a")),
         ("std_msgs/msg/String", "string data\n", _cdr_strings("b")),
         ("std_msgs/msg/String", TWO_STRINGS, _cdr_strings("c", "x"))],
    )  # fmt: skip
    with open_bag(bag, natural=False) as reader:
        table = reader.to_arrow("/s")
    assert table.column_names == ["log_time_ns", "data", "extra"]
    assert table.column("data").to_pylist() == ["a", "b", "c"]
    assert table.column("extra").to_pylist() == [None, None, "x"]


def test_columns_some_definitions_lack_are_nullable(tmp_path: Path) -> None:
    # pandas and Dask must know before reading which integer columns can hold a null.
    from pyconnect.record.tables import topic_columns
    from tests.record.test_table_pandas import two_counter_bags

    with open_bag(two_counter_bags(tmp_path), natural=False) as reader:
        columns, msg_type = topic_columns(reader, "/c")
    assert msg_type == "my_pkg/msg/Counter"
    assert [(column.name, column.nullable) for column in columns] == [
        ("kept", False), ("big", True), ("small", True), ("mid", True), ("flag", True),
    ]  # fmt: skip


# -- a field named like the log time column -------------------------------------------------------
def log_time_field_bag(path: Path) -> Path:
    """/ev of a type whose first field is named log_time_ns (a logger's own stamp)."""
    with McapRecorder(path) as recorder:
        recorder.add_topic(
            "/ev", "my_logger/msg/Event", definition="int64 log_time_ns\nfloat64 value\n"
        )
        for i in range(3):
            data = (777 + i).to_bytes(8, "little") + np.float64(0.5 * i).tobytes()
            recorder.write("/ev", b"\x00\x01\x00\x00" + data, log_time_ns=1_000 + i)
    return path


def test_a_field_named_log_time_ns_is_an_error(tmp_path: Path) -> None:
    # Two columns of one name: polars refused them, pandas gave a frame for frame["log_time_ns"].
    bag = log_time_field_bag(tmp_path / "bag")
    expected = (
        f"{bag}: /ev: field log_time_ns of my_logger/msg/Event has the name of the table's log "
        "time column; one table cannot hold both (read the topic with open_bag)"
    )
    with open_bag(bag) as reader:
        assert [m.value["log_time_ns"] for m in reader] == [777, 778, 779]
        for how in ("to_arrow", "to_pandas", "to_polars"):
            with pytest.raises(BagError) as raised:
                getattr(reader, how)("/ev")
            assert str(raised.value) == expected
    with pytest.raises(BagError) as raised:
        export_parquet(bag, tmp_path / "out")
    assert str(raised.value) == expected
    assert not list((tmp_path / "out").glob("*.parquet"))
