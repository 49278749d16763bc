"""McapRecorder: files that mcap-ros2-support and rosbags read back to the values written."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest
import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rclpy.serialization import deserialize_message, serialize_message
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore
from sensor_msgs.msg import Image
from std_msgs.msg import String
from test_msgs.msg import BasicTypes, Empty

from pyconnect.record.bag_errors import BagError
from pyconnect.record.mcap_recorder import McapRecorder
from pyconnect.typesys.installed_definition_text import installed_definition
from tests.conftest import require_sample_bags
from tests.record.bag_samples import BAGS


def read_ros2_messages(path: Path) -> list[tuple[str, object]]:
    """(topic, decoded message) of every message, decoded by mcap-ros2-support."""
    with path.open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        decoded = []
        for schema, channel, _, msg in reader.iter_decoded_messages():
            assert schema is not None
            assert schema.encoding == "ros2msg"
            assert channel.message_encoding == "cdr"
            decoded.append((channel.topic, msg))
        return decoded


def basic(i: int) -> BasicTypes:
    return BasicTypes(
        bool_value=bool(i % 2),
        int32_value=-i,
        uint64_value=2**64 - 1 - i,
        float64_value=i / 3,
    )


def image(i: int) -> Image:
    msg = Image(height=2, width=3, encoding="mono8", step=3)
    msg.header.frame_id = "cam"
    msg.header.stamp.sec = i
    msg.data.frombytes(bytes(range(i, i + 6)))
    return msg


def record_sample(path: Path, *, compression: str = "zstd") -> dict[str, list[object]]:
    written: dict[str, list[object]] = {"/basic": [], "/chatter": [], "/image": [], "/empty": []}
    with McapRecorder(path, compression=compression) as recorder:
        recorder.add_topic("/basic", "test_msgs/msg/BasicTypes")
        recorder.add_topic("/chatter", "std_msgs/String")
        recorder.add_topic("/image", "sensor_msgs/msg/Image", offered_qos_profiles="")
        recorder.add_topic("/empty", "test_msgs/msg/Empty")
        for i in range(10):
            for topic, msg in (("/basic", basic(i)), ("/chatter", String(data=f"hello {i}"))):
                recorder.write(topic, serialize_message(msg), log_time_ns=1_000 + i)
                written[topic].append(msg)
            if i % 3 == 0:
                recorder.write("/image", serialize_message(image(i)), log_time_ns=1_000 + i)
                written["/image"].append(image(i))
        recorder.write("/empty", serialize_message(Empty()), log_time_ns=2_000)
        written["/empty"].append(Empty())
    assert recorder.messages_written == 25
    return written


def test_bag_directory_layout_and_metadata(tmp_path: Path) -> None:
    record_sample(tmp_path / "run1")
    assert sorted(p.name for p in (tmp_path / "run1").iterdir()) == ["metadata.yaml", "run1_0.mcap"]
    info = yaml.safe_load((tmp_path / "run1" / "metadata.yaml").read_text())
    info = info["rosbag2_bagfile_information"]
    assert info["storage_identifier"] == "mcap"
    assert info["relative_file_paths"] == ["run1_0.mcap"]
    assert info["message_count"] == 25
    assert info["starting_time"] == {"nanoseconds_since_epoch": 1_000}
    assert info["duration"] == {"nanoseconds": 1_000}
    counts = {
        t["topic_metadata"]["name"]: t["message_count"] for t in info["topics_with_message_count"]
    }
    assert counts == {"/basic": 10, "/chatter": 10, "/image": 4, "/empty": 1}
    types = {
        t["topic_metadata"]["name"]: t["topic_metadata"]["type"]
        for t in info["topics_with_message_count"]
    }
    assert types["/chatter"] == "std_msgs/msg/String"


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_rosbags_reads_what_was_written(tmp_path: Path, compression: str) -> None:
    written = record_sample(tmp_path / "bag", compression=compression)
    # An empty typestore makes rosbags decode with the definitions stored in the file.
    typestore = get_typestore(Stores.EMPTY)
    read: dict[str, list[bytes]] = {topic: [] for topic in written}
    with AnyReader([tmp_path / "bag"], default_typestore=typestore) as reader:
        assert reader.message_count == 25
        for connection, _, raw in reader.messages():
            value = reader.deserialize(raw, connection.msgtype)
            if connection.topic == "/basic":
                expected = written["/basic"][len(read["/basic"])]
                assert isinstance(expected, BasicTypes)
                assert value.int32_value == expected.int32_value
                assert value.uint64_value == expected.uint64_value
                assert value.float64_value == expected.float64_value
            if connection.topic == "/image":
                assert value.data.tobytes() == bytes(written["/image"][len(read["/image"])].data)
            read[connection.topic].append(raw)
    for topic, messages in written.items():
        decoded = [deserialize_message(raw, type(messages[0])) for raw in read[topic]]
        assert decoded == messages


def test_mcap_ros2_reads_what_was_written(tmp_path: Path) -> None:
    written = record_sample(tmp_path / "bag.mcap")
    assert not (tmp_path / "metadata.yaml").exists()
    got: dict[str, list[object]] = {topic: [] for topic in written}
    for topic, msg in read_ros2_messages(tmp_path / "bag.mcap"):
        got[topic].append(msg)
    assert [m.data for m in got["/chatter"]] == [f"hello {i}" for i in range(10)]
    assert [m.int32_value for m in got["/basic"]] == [-i for i in range(10)]
    assert [m.uint64_value for m in got["/basic"]] == [2**64 - 1 - i for i in range(10)]
    assert [bytes(m.data) for m in got["/image"]] == [bytes(m.data) for m in written["/image"]]
    assert [m.header.frame_id for m in got["/image"]] == ["cam"] * 4
    assert len(got["/empty"]) == 1


def test_write_is_thread_safe(tmp_path: Path) -> None:
    recorder = McapRecorder(tmp_path / "threads.mcap")
    recorder.add_topic("/chatter", "std_msgs/msg/String")
    start = threading.Barrier(4)

    def produce(k: int) -> None:
        start.wait()
        for i in range(200):
            recorder.write("/chatter", serialize_message(String(data=f"{k}:{i}")), log_time_ns=i)

    threads = [threading.Thread(target=produce, args=(k,)) for k in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    recorder.close()
    texts = sorted(m.data for _, m in read_ros2_messages(tmp_path / "threads.mcap"))
    assert texts == sorted(f"{k}:{i}" for k in range(4) for i in range(200))
    assert recorder.messages_written == 800


def test_definition_layout_matches_rosbag2() -> None:
    text = installed_definition("geometry_msgs/msg/Twist")
    separator = "=" * 80
    # rosbag2 writes a newline before each separator, even after the text's own last newline
    assert f"\n\n{separator}\nMSG: geometry_msgs/Vector3\n" in text
    assert text.count("MSG: ") == 1
    assert installed_definition("test_msgs/srv/BasicTypes_Event").count("\n---\n") == 1
    odometry = installed_definition("nav_msgs/msg/Odometry")
    headers = [line for line in odometry.splitlines() if line.startswith("MSG: ")]
    assert len(headers) == len(set(headers))
    assert "MSG: builtin_interfaces/Time" in headers


def test_errors(tmp_path: Path) -> None:
    recorder = McapRecorder(tmp_path / "bag")
    recorder.add_topic("/a", "std_msgs/msg/String")
    recorder.add_topic("/a", "std_msgs/String")
    with pytest.raises(BagError) as caught:
        recorder.add_topic("/a", "std_msgs/msg/Bool")
    assert (
        str(caught.value)
        == "/a: already recorded as std_msgs/msg/String, cannot add it as std_msgs/msg/Bool"
    )
    with pytest.raises(BagError) as caught:
        recorder.write("/b", b"", log_time_ns=0)
    assert str(caught.value) == "/b: not added to this recording; call add_topic first"
    recorder.close()
    recorder.close()
    with pytest.raises(BagError) as caught:
        recorder.write("/a", b"", log_time_ns=0)
    assert str(caught.value) == f"{tmp_path / 'bag' / 'bag_0.mcap'}: recording is closed"
    with pytest.raises(BagError) as caught:
        McapRecorder(tmp_path / "bag")
    assert (
        str(caught.value)
        == f"{tmp_path / 'bag'}: already exists; a new recording needs a new directory"
    )
    with pytest.raises(
        ValueError, match=r"^compression: expected one of 'zstd', 'lz4', 'none', got 'gzip'$"
    ):
        McapRecorder(tmp_path / "x", compression="gzip")


def test_dependencies_come_in_rosbag2_jazzy_order() -> None:
    """Each text's dependencies sorted (rosbag2 keeps them in a std::set), depth first."""
    odometry = installed_definition("nav_msgs/msg/Odometry")
    headers = [line[5:] for line in odometry.splitlines() if line.startswith("MSG: ")]
    assert headers == [
        "geometry_msgs/PoseWithCovariance", "geometry_msgs/Pose", "geometry_msgs/Point",
        "geometry_msgs/Quaternion", "geometry_msgs/TwistWithCovariance", "geometry_msgs/Twist",
        "geometry_msgs/Vector3", "std_msgs/Header", "builtin_interfaces/Time",
    ]  # fmt: skip
    shared = BAGS / "evo" / "nav2_turtlebot.mcap"
    require_sample_bags(shared, shared.exists())
    with shared.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    jazzy = {s.name: s.data.decode() for s in summary.schemas.values()}
    assert odometry == jazzy["nav_msgs/msg/Odometry"]  # what rosbag2 Jazzy wrote, byte for byte


def test_the_file_holds_the_rosbag2_metadata_record(tmp_path: Path) -> None:
    from pyconnect.typesys.packages import installed_type_hash

    type_hash = installed_type_hash("std_msgs/msg/String")
    with McapRecorder(tmp_path / "bag") as recorder:
        recorder.add_topic("/chatter", "std_msgs/msg/String", type_hash=type_hash)
        for i in range(3):
            recorder.write("/chatter", serialize_message(String(data=str(i))), log_time_ns=10 + i)
    with (tmp_path / "bag" / "bag_0.mcap").open("rb") as stream:
        records = [(m.name, m.metadata) for m in make_reader(stream).iter_metadata()]
    assert [(name, list(data)) for name, data in records] == [("rosbag2", ["serialized_metadata"])]
    stored = yaml.safe_load(records[0][1]["serialized_metadata"])
    written = yaml.safe_load((tmp_path / "bag" / "metadata.yaml").read_text())
    assert stored == written["rosbag2_bagfile_information"]
    assert stored["message_count"] == 3
    assert stored["topics_with_message_count"][0]["topic_metadata"]["type_description_hash"] == (
        type_hash
    )
    assert [m.data for _, m in read_ros2_messages(tmp_path / "bag" / "bag_0.mcap")] == ["0", "1", "2"]
    with AnyReader([tmp_path / "bag"]) as reader:
        assert sum(1 for _ in reader.messages()) == 3


ACTION_PARTS = [
    "FeedbackMessage", "Goal", "Result", "Feedback", "SendGoal_Request", "SendGoal_Response",
    "GetResult_Request", "GetResult_Response", "SendGoal_Event", "GetResult_Event",
]  # fmt: skip


def test_action_parts_are_recorded_with_a_definition_rosbags_reads(tmp_path: Path) -> None:
    """rosbag2 Jazzy stores these with encoding "unknown", which rosbags refuses (the whole
    bag); pyconnect stores their .msg form, which rosbags decodes and open_bag reads."""
    from test_msgs.action import Fibonacci, NestedMessage

    from pyconnect.record.bag_reader import open_bag
    from pyconnect.typesys.classes import import_class

    sent = {}
    with McapRecorder(tmp_path / "bag") as recorder:
        for action in (Fibonacci, NestedMessage):
            for part in ACTION_PARTS:
                msg_type = f"test_msgs/action/{action.__name__}_{part}"
                message = import_class(msg_type)()
                if part == "FeedbackMessage":
                    message.goal_id.uuid[3] = 7
                    if action is Fibonacci:
                        message.feedback.sequence = [1, 1, 2]
                    else:
                        message.feedback.nested_field.int32_value = -5
                topic = f"/{action.__name__}/{part}"
                recorder.add_topic(topic, msg_type)
                recorder.write(topic, serialize_message(message), log_time_ns=len(sent))
                sent[topic] = message
    store = get_typestore(Stores.ROS2_JAZZY)
    with AnyReader([tmp_path / "bag"], default_typestore=store) as reader:
        theirs = {c.topic: reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages()}
    assert set(theirs) == set(sent)
    feedback = theirs["/Fibonacci/FeedbackMessage"]
    assert (list(feedback.goal_id.uuid)[3], list(feedback.feedback.sequence)) == (7, [1, 1, 2])
    nested = theirs["/NestedMessage/FeedbackMessage"]
    assert nested.feedback.nested_field.int32_value == -5
    with open_bag(tmp_path / "bag") as bag:
        ours = {m.topic: m.value for m in bag}
    assert bag.errors == []
    assert ours["/Fibonacci/FeedbackMessage"]["feedback"] == {"sequence": [1, 1, 2]}


# -- a full disk, a missing folder ----------------------------------------------------------------
def _noise(i: int) -> bytes:
    return bytes(serialize_message(String(data=f"{i:04d}" + "x" * 996)))


def _metadata_of(bag: Path) -> dict[str, object]:
    info: dict[str, object] = yaml.safe_load((bag / "metadata.yaml").read_text())[
        "rosbag2_bagfile_information"
    ]
    return info


@pytest.mark.parametrize("chunk_size", [1024 * 1024, 3_000], ids=["at-close", "at-a-write"])
def test_a_file_the_full_disk_cut_short_keeps_its_metadata_and_counts_what_it_holds(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, chunk_size: int
) -> None:
    """close() raised before writing metadata.yaml (node.record left a bag without one), and
    the counts were what the file was handed, not what it holds."""
    from pyconnect.record.bag_reader import open_bag
    from pyconnect.record.mcap_recorder import _CountedFile
    from tests.record.test_split_recorder import full_disk_write

    bag = tmp_path / "run"
    recorder = McapRecorder(bag, compression="none", chunk_size=chunk_size)
    recorder.add_topic("/noise", "std_msgs/msg/String")
    monkeypatch.setattr(_CountedFile, "write", full_disk_write(10_000))
    handed = 0
    for i in range(40):
        try:
            recorder.write("/noise", _noise(i), log_time_ns=1_000 + i)
        except OSError:
            break  # a chunk met the full disk: the recording stops there
        handed += 1
    assert recorder.failed == (handed < 40)
    with pytest.raises(OSError, match="No space left on device"):
        recorder.close()
    recorder.close()  # not retried
    assert recorder.failed
    with open_bag(bag) as reader:
        stamps = [m.log_time_ns for m in reader]
    assert 0 < len(stamps) < 40
    assert recorder.messages_written == len(stamps)
    assert recorder.counts == {"/noise": len(stamps)}
    assert recorder.span == (stamps[0], stamps[-1])
    metadata = _metadata_of(bag)
    assert metadata["message_count"] == len(stamps)
    assert metadata["duration"] == {"nanoseconds": stamps[-1] - stamps[0]}


def test_a_missing_folder_is_made_unless_make_parents_is_false(tmp_path: Path) -> None:
    with McapRecorder(tmp_path / "made" / "run.mcap"):
        pass
    assert (tmp_path / "made" / "run.mcap").is_file()
    with pytest.raises(FileNotFoundError):
        McapRecorder(tmp_path / "gone" / "run.mcap", make_parents=False)
    assert not (tmp_path / "gone").exists()
