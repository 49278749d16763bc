"""open_bag's ``topics=``/``types=``: what they refuse, what a read selecting none leaves out."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest
from rclpy.serialization import serialize_message
from std_msgs.msg import String

from pyconnect.record.bag_damage import BagDamage
from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_reader import open_bag
from pyconnect.record.mcap_recorder import McapRecorder


def write(path: Path, topics: dict[str, str], *, cmd_vel: str | None = None) -> Path:
    """A bag with one message on /chatter and none on its other ``topics`` (only their types
    matter here); ``cmd_vel``: the geometry_msgs type of a /cmd_vel topic too."""
    if cmd_vel is not None:
        topics = {**topics, "/cmd_vel": f"geometry_msgs/msg/{cmd_vel}"}
    with McapRecorder(path) as recorder:
        for topic, msg_type in topics.items():
            recorder.add_topic(topic, msg_type)
        recorder.write("/chatter", bytes(serialize_message(String(data="hi"))), log_time_ns=1)
    return path


@pytest.fixture
def bag(tmp_path: Path) -> Path:
    return write(
        tmp_path / "bag.mcap",
        {"/chatter": "std_msgs/msg/String", "/odom": "nav_msgs/msg/Odometry"},
    )


@pytest.mark.parametrize(
    ("wanted", "hint"),
    [
        ("nav_msgs/msg/Odometri", "; did you mean nav_msgs/msg/Odometry?"),
        ("nav_msg/msg/Odometry", "; did you mean nav_msgs/msg/Odometry?"),
        ("Odometry", "; did you mean nav_msgs/msg/Odometry?"),
        ("nav_msgs.msg.Odometry", "; did you mean nav_msgs/msg/Odometry?"),
        ("sensor_msgs/msg/Image", ""),
    ],
)
def test_a_type_the_bag_lacks_is_refused_with_its_types(bag: Path, wanted: str, hint: str) -> None:
    with pytest.raises(BagError) as error:
        open_bag(bag, types=[wanted])
    assert str(error.value) == (
        f"{bag}: no topic of type {wanted} in this bag "
        f"(types: nav_msgs/msg/Odometry, std_msgs/msg/String){hint}"
    )


def test_the_spellings_accepted_before_still_select(bag: Path) -> None:
    generator = (name for name in ["std_msgs/String"])  # read once, though checked and used
    for spelling in ("std_msgs/msg/String", "std_msgs/String", ["std_msgs/String"], generator):
        with open_bag(bag, types=spelling) as reader:
            assert list(reader.topics) == ["/chatter"]
            assert [m.value for m in reader] == ["hi"]


def test_a_type_of_one_of_several_bags_is_taken(bag: Path, tmp_path: Path) -> None:
    other = write(tmp_path / "other.mcap", {"/chatter": "std_msgs/msg/String"})
    # As with topics=: what any of the bags has counts.
    with open_bag([other, bag], types=["nav_msgs/msg/Odometry"]) as reader:
        assert list(reader.topics) == ["/odom"]
    with open_bag([other, bag], topics=["/odom"]) as reader:
        assert list(reader.topics) == ["/odom"]
    with pytest.raises(BagError) as error:
        open_bag([other, bag], types=["nav_msgs/msg/Odom"])
    assert str(error.value) == (
        f"{other}: no topic of type nav_msgs/msg/Odom in this bag "
        "(types: nav_msgs/msg/Odometry, std_msgs/msg/String); did you mean nav_msgs/msg/Odometry?"
    )


def test_a_type_a_topic_has_in_a_later_bag_only_is_taken(tmp_path: Path) -> None:
    # The merged topic's type is the first bag's (Twist): TwistStamped is still a type of it.
    old = write(tmp_path / "old.mcap", {"/chatter": "std_msgs/msg/String"}, cmd_vel="Twist")
    new = write(tmp_path / "new.mcap", {"/chatter": "std_msgs/msg/String"}, cmd_vel="TwistStamped")
    for wanted in ("geometry_msgs/msg/TwistStamped", "geometry_msgs/Twist"):
        with open_bag([old, new], types=[wanted]) as reader:
            assert list(reader.topics) == ["/cmd_vel"]


# -- topics no message of which can be decoded: JSON, protobuf, a channel with no schema -----
def write_mixed(path: Path) -> Path:
    """An MCAP bag as tools other than rosbag2 write them: /chatter (CDR) beside /json (JSON)
    and /untyped, a CDR channel with no schema; one message on each."""
    from mcap.writer import Writer

    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2", library="test")
        string = writer.register_schema("std_msgs/msg/String", "ros2msg", b"string data")
        json_schema = writer.register_schema("Foo", "jsonschema", b'{"type": "object"}')
        channels = {
            "/chatter": writer.register_channel("/chatter", "cdr", string),
            "/json": writer.register_channel("/json", "json", json_schema),
            "/untyped": writer.register_channel("/untyped", "cdr", 0),
        }
        data = {"/chatter": bytes(serialize_message(String(data="hi"))), "/json": b'{"a": 1}'}
        for time, (topic, channel) in enumerate(channels.items(), 1):
            payload = data.get(topic, data["/chatter"])
            writer.add_message(channel, log_time=time, data=payload, publish_time=time)
        writer.finish()
    return path


def test_undecodable_topics_are_left_out_of_a_read_that_selects_none(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    bag = write_mixed(tmp_path / "mixed.mcap")
    with caplog.at_level(logging.WARNING, logger="pyconnect.record"), open_bag(bag) as reader:
        values = [(m.topic, m.value) for m in reader]
    assert values == [("/chatter", "hi")]
    assert reader.errors == []
    assert list(reader.topics) == ["/chatter"]
    assert reader.left_out == {
        "/json": "serialised as 'json'",
        "/untyped": "no type: its channel has no schema",
    }
    note = (
        f"{bag}: 2 topic(s) not read, as only 'cdr' topics of a known type can be decoded: "
        "/json (serialised as 'json'), /untyped (no type: its channel has no schema); "
        "select one with raw=True to read it undecoded"
    )
    assert reader.notes == [note]
    assert [r.getMessage() for r in caplog.records] == [note]


@pytest.mark.parametrize(
    ("topic", "error"),
    [
        ("/json", "is serialised as 'json'; only 'cdr' can be decoded (raw=True reads it undecoded)"),
        ("/untyped", "has no type (its channel has no schema); raw=True reads it undecoded"),
    ],
)  # fmt: skip
def test_a_selected_undecodable_topic_is_refused(tmp_path: Path, topic: str, error: str) -> None:
    bag = write_mixed(tmp_path / "mixed.mcap")
    with pytest.raises(BagError) as caught:
        open_bag(bag, topics=["/chatter", topic])
    assert str(caught.value) == f"{bag}: topic {topic} {error}"
    with open_bag(bag, topics=[topic], raw=True) as reader:
        assert [m.topic for m in reader] == [topic]
        assert reader.notes == []


# -- types= reads only the connections of those types ----------------------------------------
TWIST = "geometry_msgs/msg/Twist"
STAMPED = "geometry_msgs/msg/TwistStamped"


def write_cmd(path: Path, msg_type: str, count: int, first_ns: int) -> Path:
    """A bag with ``count`` messages of ``msg_type`` (Twist or TwistStamped) on /cmd."""
    from geometry_msgs.msg import Twist, TwistStamped

    message = Twist() if msg_type == TWIST else TwistStamped()
    with McapRecorder(path) as recorder:
        recorder.add_topic("/cmd", msg_type)
        for i in range(count):
            recorder.write("/cmd", bytes(serialize_message(message)), log_time_ns=first_ns + i)
    return path


def channels_in_one(bags: list[Path], path: Path) -> Path:
    """One MCAP file holding every channel of ``bags``: one topic of two types in one file."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2", library="test")
        for bag in bags:
            with bag.open("rb") as source:
                mapped: dict[int, int] = {}
                for schema, channel, message in make_reader(source).iter_messages():
                    if channel.id not in mapped:
                        assert schema is not None
                        ours = writer.register_schema(schema.name, schema.encoding, schema.data)
                        mapped[channel.id] = writer.register_channel(
                            channel.topic, channel.message_encoding, ours, channel.metadata
                        )
                    writer.add_message(
                        mapped[channel.id], message.log_time, message.data, message.publish_time
                    )
        writer.finish()
    return path


@pytest.fixture(params=["merged bags", "one file"])
def two_types(request: pytest.FixtureRequest, tmp_path: Path) -> list[Path]:
    """/cmd as 3 Twist messages, then as 2 TwistStamped ones: in two bags read merged, or as
    two channels of one file."""
    bags = [
        write_cmd(tmp_path / "a.mcap", TWIST, 3, 100),
        write_cmd(tmp_path / "b.mcap", STAMPED, 2, 200),
    ]
    if request.param == "one file":
        return [channels_in_one(bags, tmp_path / "ab.mcap")]
    return bags


@pytest.mark.parametrize(
    ("wanted", "msg_type", "count"),
    [
        ([STAMPED], STAMPED, 2),
        (["geometry_msgs/TwistStamped"], STAMPED, 2),
        (["geometry_msgs/Twist"], TWIST, 3),
        ([TWIST, STAMPED], TWIST, 5),
    ],
)
def test_types_read_only_the_messages_of_those_types(
    two_types: list[Path], wanted: list[str], msg_type: str, count: int
) -> None:
    both = len(wanted) == 2
    for topics in (None, ["/cmd"]):
        for raw in (False, True):
            with open_bag(two_types, topics=topics, types=wanted, raw=raw) as reader:
                read = list(reader)
                info = reader.topics["/cmd"]
                codecs = [codec.msg_type for _bag, codec in reader.topic_codecs("/cmd")]
                # What a damaged read would say it promised: the messages of these types.
                summary = reader.damage_summary([BagDamage("f", None, "cut")])
            types = [m.msg_type for m in read]
            assert types == ([TWIST] * 3 + [STAMPED] * 2 if both else [msg_type] * count)
            assert (info.msg_type, info.message_count) == (msg_type, count)
            assert reader.types == {"geometry_msgs/msg/" + t.rsplit("/", 1)[1] for t in wanted}
            assert codecs == ([TWIST, STAMPED] if both else [msg_type])
            assert summary.endswith(f"{count} message(s) read, the bag's metadata promised {count}")
