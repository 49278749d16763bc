"""``pyconnect bag record``: the topics of service and action parts, its options, a full disk."""

from __future__ import annotations

import argparse
import contextlib
import io
import re
import shutil
import signal
from collections.abc import Iterator
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
import yaml
from mcap.reader import make_reader
from rclpy.qos import QoSProfile
from rclpy.serialization import serialize_message
from rclpy.topic_endpoint_info import TopicEndpointInfo, TopicEndpointTypeEnum
from rclpy.type_hash import TypeHash
from std_msgs.msg import String
from test_msgs.action import Fibonacci

from pyconnect.cli import main
from pyconnect.commands import bag_record
from pyconnect.record import BagError, open_bag
from pyconnect.record.queued_recorder import QueuedRecorder
from pyconnect.record.split_recorder import SplitRecorder
from pyconnect.typesys.packages import installed_type_hash
from tests.commands.processes import WAIT, Lines, spawn


class _Node:
    """What `_subscribe_new` asks of the graph, with the topics `ros2 topic list -t` shows."""

    def __init__(self, topics: list[tuple[str, list[str]]]) -> None:
        self.topics = topics
        self.subscriptions: dict[str, Any] = {}
        self.events: dict[str, Any] = {}
        """Each topic's ``event_callbacks``, for a test to fire."""
        self.warnings: list[str] = []

    def get_topic_names_and_types(self) -> list[tuple[str, list[str]]]:
        return self.topics

    def get_publishers_info_by_topic(self, _topic: str) -> list[Any]:
        return []

    def create_subscription(
        self, cls: type, topic: str, callback: Any, qos: Any, **options: Any
    ) -> SimpleNamespace:
        self.subscriptions[topic] = (cls, callback)
        self.events[topic] = options["event_callbacks"]
        return SimpleNamespace(topic_name=topic, qos_profile=qos)

    def get_logger(self) -> Any:
        return SimpleNamespace(info=lambda _text: None, warning=self.warnings.append)


def test_an_action_feedback_topic_named_explicitly_is_recorded(tmp_path: Path) -> None:
    feedback = "/fib/_action/feedback"
    node = _Node([(feedback, ["test_msgs/action/Fibonacci_FeedbackMessage"]),
                  ("/events", ["test_msgs/srv/BasicTypes_Event"])])  # fmt: skip
    writer = QueuedRecorder(SplitRecorder(tmp_path / "run"))
    out = io.StringIO()
    session: Any = SimpleNamespace(node=node)
    bag_record._subscribe_new(session, writer, {feedback, "/events"}, set(), out, readers={})
    assert "skipping" not in out.getvalue()
    cls, callback = node.subscriptions[feedback]
    assert cls is Fibonacci.Impl.FeedbackMessage
    message = Fibonacci.Impl.FeedbackMessage()
    message.feedback.sequence = [1, 1, 2]
    callback(serialize_message(message))
    writer.close()
    with open_bag(tmp_path / "run") as bag:
        values = [m.value for m in bag]
    assert bag.errors == []
    assert [v["feedback"] for v in values] == [{"sequence": [1, 1, 2]}]


def _publisher(type_hash: TypeHash, msg_type: str = "std_msgs/msg/String") -> TopicEndpointInfo:
    return TopicEndpointInfo(
        node_name="talker", topic_type=msg_type, topic_type_hash=type_hash,
        endpoint_type=TopicEndpointTypeEnum.PUBLISHER, qos_profile=QoSProfile(depth=10),
    )  # fmt: skip


class _Published(_Node):
    """A graph whose topics have ``publishers``."""

    def __init__(self, topics: list[tuple[str, list[str]]], publishers: list[Any]) -> None:
        super().__init__(topics)
        self.publishers = publishers

    def get_publishers_info_by_topic(self, _topic: str) -> list[Any]:
        return self.publishers


OTHER = TypeHash(version=1, value=bytes(range(32)))  # a std_msgs/String that is not installed
OTHER_TEXT = "RIHS01_" + bytes(range(32)).hex()


@pytest.mark.parametrize(
    ("publishers", "stored"),
    [
        ([_publisher(OTHER), _publisher(OTHER)], OTHER_TEXT),
        ([_publisher(OTHER), _publisher(TypeHash(version=1, value=bytes(32)))], ""),  # disagree
    ],
)
def test_the_publishers_type_hash_is_what_the_bag_stores(
    tmp_path: Path, publishers: list[Any], stored: str
) -> None:
    """The bag stored no hash: open_bag's check of a type that changed could never fire."""
    node = _Published([("/chatter", ["std_msgs/msg/String"])], publishers)
    writer = QueuedRecorder(SplitRecorder(tmp_path / "run"))
    session: Any = SimpleNamespace(node=node)
    bag_record._subscribe_new(session, writer, {"/chatter"}, set(), io.StringIO(), readers={})
    _cls, callback = node.subscriptions["/chatter"]
    callback(serialize_message(String(data="hi")))
    writer.close()
    metadata = yaml.safe_load((tmp_path / "run" / "metadata.yaml").read_text())
    (topic,) = metadata["rosbag2_bagfile_information"]["topics_with_message_count"]
    assert topic["topic_metadata"]["type_description_hash"] == stored
    with open_bag(tmp_path / "run") as bag:
        assert bag.topics["/chatter"].type_hash == stored
        assert [m.value for m in bag] == ["hi"]
    assert [m.bag_hash for m in bag.mismatches] == ([stored] if stored else [])


def test_a_live_publishers_type_hash_is_recorded(peer: Lines, tmp_path: Path) -> None:
    """`topic info -v` showed the publisher's RIHS01 hash; the bag stored '' for it."""
    bag = tmp_path / "run"
    recorder = spawn("-m", "pyconnect.cli", "bag", "record", "/chatter", "-o", str(bag))
    lines = Lines(recorder)
    try:
        lines.wait_for("^Recording '/chatter': first message received$")
    finally:
        err = lines.stop()
    assert (recorder.returncode, err) == (0, "")
    published = installed_type_hash("std_msgs/msg/String")  # the peer's rclpy String
    assert published is not None and published.startswith("RIHS01_")
    metadata = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    (topic,) = metadata["topics_with_message_count"]
    assert topic["topic_metadata"]["type_description_hash"] == published
    with (bag / "run_0.mcap").open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    assert [c.metadata["topic_type_hash"] for c in summary.channels.values()] == [published]
    with open_bag(bag) as reader:
        assert reader.topics["/chatter"].type_hash == published
        assert all(m.value.startswith("hello ") for m in reader)
    assert reader.mismatches == []


@pytest.mark.parametrize(
    ("option", "error"),
    [
        ("--max-bag-size", "expected a whole number of bytes >= 0 (0: no split), got '-1'"),
        ("--max-bag-duration", "expected a number of seconds >= 0 (0: no split), got '-1'"),
    ],
)
def test_a_negative_split_limit_is_a_usage_error(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    option: str,
    error: str,
) -> None:
    # It was taken: every message got a file of its own.
    def record(*_: object) -> int:
        pytest.fail("recording started")

    monkeypatch.setattr(bag_record, "_record", record)
    short = {"--max-bag-size": "-b", "--max-bag-duration": "-d"}[option]
    assert main(["bag", "record", "/chatter", "-o", str(tmp_path / "run"), option, "-1"]) == 2
    assert capsys.readouterr().err == f"pyconnect: error: argument {short}/{option}: {error}\n"
    assert not (tmp_path / "run").exists()


def test_a_split_duration_no_ns_count_holds_is_a_usage_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # 1e300 s passed the check, then overflowed the limit in nanoseconds: a traceback.
    argv = ["bag", "record", "/chatter", "-o", str(tmp_path / "run"), "-d", "1e300"]
    assert main(argv) == 2
    assert capsys.readouterr().err == (
        "pyconnect: error: argument -d/--max-bag-duration: expected at most 9.22e+09 seconds "
        "(0: no split), got '1e300'\n"
    )


@pytest.mark.parametrize("seconds", ["1e-10", "4.9e-10", "5e-10"])
def test_a_split_duration_below_one_ns_is_a_usage_error(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    seconds: str,
) -> None:
    # 1e-10 s is a positive duration, yet it rounded to a 0 ns limit: silently never split.
    def record(*_: object) -> int:
        pytest.fail("recording started")

    monkeypatch.setattr(bag_record, "_record", record)
    argv = ["bag", "record", "/chatter", "-o", str(tmp_path / "run"), "-d", seconds]
    assert main(argv) == 2
    assert capsys.readouterr().err == (
        "pyconnect: error: argument -d/--max-bag-duration: expected at least 1e-09 seconds "
        f"(0: no split), got {seconds!r}\n"
    )
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("seconds", ["1e-9", "0", "1.5"])
def test_a_split_duration_of_one_ns_or_more_or_0_is_taken(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, seconds: str
) -> None:
    taken: list[float] = []

    def record(args: argparse.Namespace, *_: object) -> int:
        taken.append(args.max_bag_duration)
        return 0

    monkeypatch.setattr(bag_record, "_record", record)
    argv = ["bag", "record", "/chatter", "-o", str(tmp_path / "run"), "-d", seconds]
    assert main(argv) == 0
    assert taken == [float(seconds)]


def test_a_bag_that_cannot_be_finished_still_says_what_it_recorded(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The session never starts and closing the bag fails: both are told, the SIGTERM handler
    is given back."""

    def no_session(_name: str) -> Any:
        raise RuntimeError("no ROS graph")

    def failing_close(self: QueuedRecorder) -> None:
        raise BagError("the bag could not be finished")

    from pyconnect.commands import graph

    monkeypatch.setattr(graph, "graph_session", no_session)
    monkeypatch.setattr(QueuedRecorder, "close", failing_close)
    before = signal.getsignal(signal.SIGTERM)
    out = io.StringIO()
    args = argparse.Namespace(
        all=False, topics=["/chatter"], output=str(tmp_path / "run"), max_bag_size=0,
        max_bag_duration=0.0,
    )  # fmt: skip
    with pytest.raises(BagError) as failed:
        bag_record._record(args, out, io.StringIO())
    assert str(failed.value) == "the bag could not be finished"
    assert str(failed.value.__context__) == "no ROS graph"
    assert out.getvalue() == f"Recorded 0 message(s) to '{tmp_path / 'run'}'\n"
    assert signal.getsignal(signal.SIGTERM) is before


def _lost(total: int, change: int) -> SimpleNamespace:
    """A ``message_lost`` event's status: the reader's total and what it adds."""
    return SimpleNamespace(total_count=total, total_count_change=change)


def test_messages_dds_lost_are_warned_once_and_counted_per_topic_in_the_last_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A 30 Hz 1080p camera recorded 136 of 178 frames, exit 0, and nothing said so: the readers
    had no message_lost event (DDS cannot lose on cue: the test fires the registered event)."""
    from pyconnect.ros import following_subscription

    # Counted where the rmw can take the event without deadlocking (not Fast DDS).
    monkeypatch.setattr(following_subscription, "_losses_deadlock", lambda: False)
    from pyconnect.commands import graph

    node = _Node([("/hd", ["std_msgs/msg/String"]), ("/odom", ["std_msgs/msg/String"])])

    class Session:
        def __init__(self) -> None:
            self.node = node
            self.spins = 0

        @contextlib.contextmanager
        def interrupts_deferred(self) -> Iterator[None]:
            yield

        def spin_for(self, _seconds: float) -> None:
            self.spins += 1
            if self.spins == 1:
                _cls, callback = node.subscriptions["/hd"]
                callback(serialize_message(String(data="kept")))
                node.events["/hd"].message_lost(_lost(3, 3))
                node.events["/hd"].message_lost(_lost(42, 39))
                node.events["/odom"].message_lost(_lost(0, 0))
                return
            raise KeyboardInterrupt  # Ctrl-C: the recording ends

    @contextlib.contextmanager
    def session(_name: str) -> Iterator[Session]:
        yield Session()

    monkeypatch.setattr(graph, "graph_session", session)
    out = io.StringIO()
    bag = tmp_path / "run"
    args = argparse.Namespace(
        all=False, topics=["/hd", "/odom"], output=str(bag), max_bag_size=0, max_bag_duration=0.0
    )
    assert bag_record._record(args, out, io.StringIO()) == 0  # a loss is no failure of the bag
    assert node.warnings == [
        "recording /hd: DDS lost 3 message(s) so far before they reached the recorder; they are "
        "not in the bag (the recording's end counts them all)"
    ]
    assert out.getvalue().splitlines()[-1] == (
        f"Recorded 1 message(s) to '{bag}'; DDS lost 42 message(s) (/hd: 42) before they "
        "reached the recorder"
    )


def test_a_full_disk_is_reported_with_the_bag_and_what_it_lost(peer: Lines, tmp_path: Path) -> None:
    # Chunks of a few messages: the disk fills while /chatter is recorded; the writer's failure
    # ends the recording (the next message is refused), then finishing the file may fail too.
    bag = tmp_path / "run"
    argv = ["bag", "record", "/chatter", "-o", str(bag), "--max-bag-size", "200"]
    recorder = spawn("-m", "tests.commands.full_disk_record", "3000", *argv)
    lines = Lines(recorder)
    try:
        lines.wait_for("^Recording '/chatter': first message received$")
        status = recorder.wait(timeout=WAIT)  # the recording ends by itself
    finally:
        err = lines.stop()
    assert status == 2
    no_space = r"\(\[Errno 28\] No space left on device\)"
    found = re.fullmatch(
        rf"pyconnect: error: {re.escape(str(bag))}: writing the bag failed {no_space}; "
        rf"(\d+) received message\(s\) not written(; finishing it failed too {no_space})?\n",
        err,
    )
    assert found, err
    with open_bag(bag) as reader:
        held = sum(1 for _ in reader)
    assert held > 0 and int(found.group(1)) > 0
    metadata = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert metadata["message_count"] == held
    _seen, recorded = lines.wait_for("^Recorded ")
    assert recorded.string == f"Recorded {held} message(s) to '{bag}'"


def test_a_bag_directory_removed_while_recorded_ends_it_with_what_it_lost(
    peer: Lines, tmp_path: Path
) -> None:
    # It was made again, empty, at the next split: exit 0, every message claimed recorded,
    # and a metadata.yaml listing the files removed with the first one (bag info failed).
    bag = tmp_path / "run"
    argv = ["bag", "record", "/chatter", "-o", str(bag), "--max-bag-duration", "0.2"]
    recorder = spawn("-m", "pyconnect.cli", *argv)
    lines = Lines(recorder)
    try:
        lines.wait_for("^Recording '/chatter': first message received$")
        shutil.rmtree(bag)
        status = recorder.wait(timeout=WAIT)  # the next split finds it gone: the end
    finally:
        err = lines.stop()
    assert status == 2
    found = re.fullmatch(
        rf"pyconnect: error: {re.escape(str(bag))}: writing the bag failed "
        rf"\({re.escape(str(bag))}: the directory was removed while it was recorded, its files "
        r"with it\); (\d+) received message\(s\) not written\n",
        err,
    )
    assert found, err
    assert int(found.group(1)) > 0
    assert not bag.exists()
    _seen, recorded = lines.wait_for("^Recorded ")
    assert recorded.string == f"Recorded 0 message(s) to '{bag}'"
