"""``bag_info`` (``pyconnect.record.bag_info``): a topic carried by two types is listed per type."""

from __future__ import annotations

from pathlib import Path

from rclpy.serialization import serialize_message
from std_msgs.msg import Float64, String

from pyconnect.record.bag_info import bag_info
from pyconnect.record.bag_reader import open_bag
from pyconnect.record.mcap_recorder import McapRecorder
from pyconnect.typesys.installed_definition_text import installed_definition

STRING = "std_msgs/msg/String"
FLOAT = "std_msgs/msg/Float64"


def write_mixed(path: Path, *, strings: int = 4, floats: int = 3) -> Path:
    """One MCAP file with /mixed on two channels (String and Float64), and /other."""
    from mcap.writer import Writer

    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2", library="test")
        channels = {}
        for msg_type in (STRING, FLOAT):
            schema = writer.register_schema(
                msg_type, "ros2msg", installed_definition(msg_type).encode()
            )
            channels[msg_type] = writer.register_channel("/mixed", "cdr", schema)
        other = writer.register_channel("/other", "cdr", schema)
        for i in range(strings):
            data = bytes(serialize_message(String(data=f"s{i}")))
            writer.add_message(channels[STRING], log_time=10 * i, data=data, publish_time=0)
        for i in range(floats):
            data = bytes(serialize_message(Float64(data=float(i))))
            writer.add_message(channels[FLOAT], log_time=10 * i + 1, data=data, publish_time=0)
        writer.add_message(other, log_time=100, data=data, publish_time=0)
        writer.finish()
    return path


def test_a_topic_of_two_types_is_listed_once_per_type(tmp_path: Path) -> None:
    info = bag_info(write_mixed(tmp_path / "mixed.mcap"))
    assert [(t.name, t.msg_type, t.message_count) for t in info.topics] == [
        ("/mixed", STRING, 4),
        ("/mixed", FLOAT, 3),
        ("/other", FLOAT, 1),
    ]
    assert info.message_count == 8


def test_a_topic_of_two_types_in_merged_bags_is_listed_once_per_type(tmp_path: Path) -> None:
    bags = []
    for msg_type, message, count in ((STRING, String(data="x"), 2), (FLOAT, Float64(), 5)):
        bag = tmp_path / msg_type.rsplit("/", 1)[1]
        with McapRecorder(bag) as recorder:  # a metadata.yaml listing the topic with its type
            recorder.add_topic("/t", msg_type)
            for i in range(count):
                recorder.write("/t", bytes(serialize_message(message)), log_time_ns=1 + i)
        bags.append(bag)
    info = bag_info(bags)
    assert [(t.name, t.msg_type, t.message_count) for t in info.topics] == [
        ("/t", STRING, 2),
        ("/t", FLOAT, 5),
    ]
    assert info.damage == ()


def test_readers_take_every_type_of_a_topic_listed_twice(tmp_path: Path) -> None:
    bag = write_mixed(tmp_path / "mixed.mcap")
    with open_bag(bag) as reader:
        types = [m.msg_type for m in reader if m.topic == "/mixed"]
        # The reader's entry for the topic stands for all of its messages, of either type.
        assert reader.topics["/mixed"].message_count == 7
    assert types.count(STRING) == 4 and types.count(FLOAT) == 3
    with open_bag(bag, types=[FLOAT]) as reader:
        assert sorted(reader.topics) == ["/mixed", "/other"]
        assert (reader.topics["/mixed"].msg_type, reader.topics["/mixed"].message_count) == (
            FLOAT,
            3,
        )
        assert [m.topic for m in reader].count("/mixed") == 3


def test_a_type_spelled_otherwise_in_metadata_yaml_is_no_second_type(tmp_path: Path) -> None:
    """metadata.yaml's ``std_msgs/Int64`` for the file's ``std_msgs/msg/Int64`` added a row
    of 0 messages, as if the topic had a second type."""
    bag = tmp_path / "bag"
    with McapRecorder(bag) as recorder:
        recorder.add_topic("/n", "std_msgs/msg/Int64")
        recorder.write_value("/n", 7, log_time_ns=1)
    metadata = bag / "metadata.yaml"
    metadata.write_text(metadata.read_text().replace("std_msgs/msg/Int64", "std_msgs/Int64"))
    rows = [(t.name, t.msg_type, t.message_count) for t in bag_info(bag).topics]
    assert rows == [("/n", "std_msgs/msg/Int64", 1)]
