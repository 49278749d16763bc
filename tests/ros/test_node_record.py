"""node.record(): one subscription per topic, subscribed with the publishers' QoS, as bag record."""

from __future__ import annotations

import re
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import yaml
from mcap.reader import make_reader
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_reader import open_bag
from pyconnect.ros.recording import Recording

from .conftest import EVENT_TIMEOUT, repeat_until
from .test_following_subscription import WarningsLogged, lost, message_lost_callback


def _recorded(bag: Path) -> list[Any]:
    with open_bag(bag) as reader:
        return [value for _topic, _stamp, value in reader]


def _wait_for(done: Callable[[], bool]) -> bool:
    """Until ``done()`` (a count reached); False after the timeout."""
    reached = threading.Event()
    return repeat_until(reached, lambda: reached.set() if done() else None)


def _start_by_record(node: Any, bag: Path) -> Recording:
    recording: Recording = node.record(bag)
    return recording


def _start_by_naming_the_topic_twice(node: Any, bag: Path) -> Recording:
    recording: Recording = node.record(bag, topics=["chatter", "/chatter", "second"])
    return recording


def _start_by_log_subs(node: Any, bag: Path) -> Recording:
    node.start_log_subs(fps=1, record=bag)
    recording: Recording = node._log_subs_recording
    return recording


@pytest.mark.parametrize(
    "start", [_start_by_record, _start_by_naming_the_topic_twice, _start_by_log_subs]
)
def test_two_sub_agents_on_one_topic_record_each_message_once(
    make_node: Any, tmp_path: Path, start: Callable[[Any, Path], Recording]
) -> None:
    """Each sub agent's topic got a subscription of its own, both writing into one channel:
    5 messages published, 10 recorded."""
    node = make_node("dup_recorder", log_dir=tmp_path / "logs")
    first = node.add_agent(conn_name="chatter", conn_type="sub", data_interface=String)
    second = node.add_agent(
        conn_name="chatter", agent_name="second", conn_type="sub", data_interface=String
    )
    pub = node.add_agent(
        conn_name="chatter", agent_name="out", conn_type="pub", data_interface=String
    )
    bag = tmp_path / "dup"
    recording = start(node, bag)
    assert recording.topics == ["/chatter"]
    node.spin(run_thread=True)
    ready = threading.Event()

    def warm_up() -> None:
        pub.send("warm")
        if recording.messages_written and first.message_count and second.message_count:
            ready.set()

    assert repeat_until(ready, warm_up)
    before = recording.messages_written
    for i in range(5):
        pub.send(f"m{i}")
    # Every message reaches both agents and the recording (reliable, one node).
    assert _wait_for(lambda: recording.messages_written >= before + 5)
    assert _wait_for(lambda: first.get() == "m4" and second.get() == "m4")
    if recording is node._log_subs_recording:
        node.stop_log_subs()
    else:
        recording.stop()
    assert [value for value in _recorded(bag) if value != "warm"] == [f"m{i}" for i in range(5)]


def test_a_burst_the_agent_receives_is_recorded_whole(make_node: Any, tmp_path: Path) -> None:
    """Recorded best effort, keep last 5: of 300 reliable messages the agent got, 5 recorded."""
    publisher_node, node = make_node("burst_pub"), make_node("burst_sub")
    deep = QoSProfile(depth=1000)
    pub = publisher_node.add_agent(
        conn_name="burst", conn_type="pub", data_interface=String, qos=deep
    )
    received: list[str] = []
    sub = node.add_agent(
        conn_name="burst",
        conn_type="sub",
        data_interface=String,
        qos=deep,
        response_func=received.append,
    )
    publisher_node.spin(run_thread=True)
    node.spin(run_thread=True)
    # The recording follows the publishers it sees, so it starts once they are discovered.
    discovered = threading.Event()

    def discover() -> None:
        pub.send("warm")
        if sub.message_count and node.count_publishers("/burst"):
            discovered.set()

    assert repeat_until(discovered, discover)
    recording = node.record(tmp_path / "burst")
    recording_hears = threading.Event()

    def warm_up() -> None:
        pub.send("warm")
        if recording.messages_written:
            recording_hears.set()

    assert repeat_until(recording_hears, warm_up)
    before = recording.messages_written
    for i in range(300):
        pub.send(f"b{i}")
    assert _wait_for(lambda: received[-1:] == ["b299"])
    assert _wait_for(lambda: recording.messages_written >= before + 300)
    recording.stop()
    burst = [value for value in _recorded(tmp_path / "burst") if value != "warm"]
    assert burst == [f"b{i}" for i in range(300)]


def test_a_latched_message_sent_before_recording_is_recorded(
    make_node: Any, tmp_path: Path
) -> None:
    """Recorded volatile: the map the latched agent got was never recorded; and the bag stored
    no offered_qos_profiles for bag play to offer again."""
    publisher_node = make_node("map_pub")
    publisher_node.add_agent(
        conn_name="map", conn_type="pub", data_interface=String, qos="latched"
    ).send("the map")
    publisher_node.spin(run_thread=True)
    node = make_node("map_sub")
    got_map = threading.Event()
    node.add_agent(
        conn_name="map",
        conn_type="sub",
        data_interface=String,
        qos="latched",
        response_func=lambda _value: got_map.set(),
    )
    node.spin(run_thread=True)
    assert got_map.wait(EVENT_TIMEOUT)
    bag = tmp_path / "map"
    recording = node.record(bag)
    assert _wait_for(lambda: recording.messages_written >= 1)
    recording.stop()
    assert _recorded(bag) == ["the map"]
    metadata = yaml.safe_load((bag / "metadata.yaml").read_text())
    (topic,) = metadata["rosbag2_bagfile_information"]["topics_with_message_count"]
    offered = yaml.safe_load(topic["topic_metadata"]["offered_qos_profiles"])
    assert [(p["reliability"], p["durability"]) for p in offered] == [(1, 1)]  # reliable, latched


def test_the_publishers_type_hash_is_stored_and_read_back(make_node: Any, tmp_path: Path) -> None:
    """metadata.yaml's type_description_hash (and the MCAP channel's topic_type_hash) was ''
    though the publisher gave its RIHS01 hash: open_bag could never tell a changed type."""
    publisher_node = make_node("hash_pub")
    publisher_node.add_agent(
        conn_name="hashed", conn_type="pub", data_interface=String, time_period=0.05,
        response_func=lambda: "hi",
    )  # fmt: skip
    publisher_node.spin(run_thread=True)
    node = make_node("hash_rec")
    node.spin(run_thread=True)
    assert _wait_for(lambda: bool(node.get_publishers_info_by_topic("/hashed")))
    (publisher,) = node.get_publishers_info_by_topic("/hashed")
    published = str(publisher.topic_type_hash)
    assert published.startswith("RIHS01_")
    bag = tmp_path / "hashed"
    recording = node.record(bag, topics=["/hashed"])
    assert _wait_for(lambda: recording.messages_written >= 1)
    recording.stop()
    metadata = yaml.safe_load((bag / "metadata.yaml").read_text())
    (topic,) = metadata["rosbag2_bagfile_information"]["topics_with_message_count"]
    assert topic["topic_metadata"]["type_description_hash"] == published
    with (bag / "hashed_0.mcap").open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    assert [c.metadata["topic_type_hash"] for c in summary.channels.values()] == [published]
    with open_bag(bag) as reader:
        assert reader.topics["/hashed"].type_hash == published
        assert set(value for _topic, _stamp, value in reader) == {"hi"}
    assert reader.mismatches == []


def test_a_recording_started_before_its_publisher_hears_a_best_effort_one(
    make_node: Any, tmp_path: Path
) -> None:
    """The recording subscribed at once, reliable as no publisher was known yet: a best-effort
    driver discovered later was never heard (none of its messages recorded)."""
    node = make_node("early_recorder")
    node.add_agent(conn_name="scan", conn_type="sub", data_interface=String)
    node.spin(run_thread=True)
    recording = node.record(tmp_path / "early")
    driver = make_node("driver")
    best_effort = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
    pub = driver.add_agent(
        conn_name="scan", conn_type="pub", data_interface=String, qos=best_effort
    )
    driver.spin(run_thread=True)
    heard = threading.Event()

    def send() -> None:
        pub.send("scan")
        if recording.messages_written:
            heard.set()

    assert repeat_until(heard, send)
    recording.stop()
    assert set(_recorded(tmp_path / "early")) == {"scan"}


RELIABLE_LATCHED = QoSProfile(
    depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)
BEST_EFFORT = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
RELIABLE_VOLATILE = QoSProfile(depth=10)


@pytest.mark.parametrize(
    ("first", "late"),
    [(RELIABLE_VOLATILE, BEST_EFFORT), (RELIABLE_LATCHED, RELIABLE_VOLATILE)],
    ids=["best-effort-after-reliable", "volatile-after-latched"],
)
def test_a_publisher_offering_less_that_appears_later_is_recorded(
    make_node: Any, tmp_path: Path, first: QoSProfile, late: QoSProfile
) -> None:
    """The recording chose its QoS from the publishers known when it subscribed: a best-effort
    (or volatile) publisher appearing later was never heard, though the node's agent was."""
    node = make_node("late_recorder")
    node.add_agent(conn_name="scan", conn_type="sub", data_interface=String, qos=BEST_EFFORT)
    node.spin(run_thread=True)
    driver = make_node("late_driver")
    early = driver.create_publisher(String, "scan", first)
    recording = node.record(tmp_path / "late")
    heard_first = threading.Event()

    def send_first() -> None:
        early.publish(String(data="first"))
        if recording.messages_written:
            heard_first.set()

    assert repeat_until(heard_first, send_first)
    heard_late = threading.Event()
    write = recording.recorder.write

    def spy(topic: str, cdr: bytes, **options: Any) -> None:
        if b"late" in bytes(cdr):
            heard_late.set()
        write(topic, cdr, **options)

    recording.recorder.write = spy  # type: ignore[method-assign]
    later = driver.create_publisher(String, "scan", late)
    assert repeat_until(heard_late, lambda: later.publish(String(data="late")))
    recording.stop()
    assert "late" in _recorded(tmp_path / "late")


def test_a_remapped_agent_topic_is_recorded_from_that_topic(make_node: Any, tmp_path: Path) -> None:
    """The recording subscribed to the agent's resolved topic, which the node's rules remapped
    again: under ``left:=right right:=left`` /left's messages were recorded as /right's."""
    node = make_node(
        "swapped_recorder", args=["--ros-args", "-r", "left:=right", "-r", "right:=left"]
    )
    agent = node.add_agent(conn_name="left", conn_type="sub", data_interface=String)
    assert agent.topic == "/right"
    node.spin(run_thread=True)
    driver = make_node("swap_driver")
    on_left = driver.create_publisher(String, "/left", 10)
    on_right = driver.create_publisher(String, "/right", 10)
    recording = node.record(tmp_path / "swapped")
    assert recording.topics == ["/right"]

    def send_both() -> None:
        on_left.publish(String(data="left"))
        on_right.publish(String(data="right"))

    assert _wait_for_after(send_both, lambda: recording.messages_written >= 3)
    recording.stop()
    with open_bag(tmp_path / "swapped") as reader:
        assert {(topic, value) for topic, _stamp, value in reader} == {("/right", "right")}


def _wait_for_after(action: Callable[[], object], done: Callable[[], bool]) -> bool:
    """Do ``action`` until ``done()``; False after the timeout."""
    reached = threading.Event()

    def step() -> None:
        action()
        if done():
            reached.set()

    return repeat_until(reached, step)


def test_under_sim_time_without_a_clock_the_recording_still_subscribes(
    make_node: Any, tmp_path: Path
) -> None:
    """The recording's discovery timer ran on the node's clock: with use_sim_time and no
    /clock it never fired, and a publisher that appeared after record() was never recorded."""
    node = make_node("sim_recorder", args=["--ros-args", "-p", "use_sim_time:=true"])
    node.add_agent(conn_name="sim_status", conn_type="sub", data_interface=String)
    node.spin(run_thread=True)
    recording = node.record(tmp_path / "sim")
    pub = make_node("sim_driver").create_publisher(String, "sim_status", 10)
    assert _wait_for_after(
        lambda: pub.publish(String(data="s")), lambda: recording.messages_written >= 1
    )
    recording.stop()
    assert set(_recorded(tmp_path / "sim")) == {"s"}


def test_stopped_recordings_are_let_go(make_node: Any, tmp_path: Path) -> None:
    """One recording per episode: every stopped one stayed in the node's list for its life."""
    node = make_node("episodes")
    node.add_agent(conn_name="episode", conn_type="sub", data_interface=String)
    for episode in range(5):
        node.record(tmp_path / f"episode{episode}").stop()
    last = node.record(tmp_path / "last")
    assert node._recordings == [last]


class _ErrorsLogged:
    """The node's logger, keeping what is logged as an error."""

    def __init__(self, logger: Any) -> None:
        self.logger = logger
        self.errors: list[str] = []

    def error(self, message: str, **options: Any) -> bool:
        self.errors.append(message)
        result: bool = self.logger.error(message, **options)
        return result

    def __getattr__(self, name: str) -> Any:
        return getattr(self.logger, name)


def test_a_full_disk_ends_the_writing_once_and_stop_counts_what_was_lost(
    make_node: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The write raised in the callback: a FATAL and a traceback per message for as long as the
    disk was full, then stop() raised a bare OSError, left no metadata.yaml, counted nothing."""
    from pyconnect.record.mcap_recorder import _CountedFile
    from tests.record.test_split_recorder import full_disk_write

    node = make_node("full_recorder")
    node.add_agent(conn_name="chatter", conn_type="sub", data_interface=String)
    pub = node.add_agent(
        conn_name="chatter", agent_name="out", conn_type="pub", data_interface=String,
        qos=QoSProfile(depth=100),
    )  # fmt: skip
    logged = _ErrorsLogged(node.get_logger())
    monkeypatch.setattr(node, "get_logger", lambda: logged)
    raised: list[str] = []
    monkeypatch.setattr(node, "_log_error", raised.append)
    bag = tmp_path / "full"
    recording = node.record(bag)
    node.spin(run_thread=True)
    assert _wait_for_after(lambda: pub.send("warm"), lambda: recording.messages_written >= 1)
    monkeypatch.setattr(_CountedFile, "write", full_disk_write(0))  # the disk is full now
    before = recording.messages_received
    for i in range(8):  # 2 MiB: a chunk (1 MiB) is closed, and meets the full disk
        pub.send(f"{i}" + "x" * 300_000)
    assert _wait_for(lambda: recording.messages_received >= before + 8)
    assert isinstance(recording.error, OSError)
    assert raised == []  # nothing reached the executor
    assert logged.errors == [
        f"record: {bag}: writing the bag failed ([Errno 28] No space left on device); the "
        "messages received from now on are not written (stop() counts them)"
    ]
    with pytest.raises(BagError) as failed:
        recording.stop()
    recording.stop()  # reported once
    received = recording.messages_received
    held = len(_recorded(bag))
    assert recording.messages_written == held < received
    no_space = r"\(\[Errno 28\] No space left on device\)"
    assert re.fullmatch(
        rf"{re.escape(str(bag))}: writing the bag failed {no_space}; {received - held} received "
        rf"message\(s\) not written(; finishing it failed too {no_space})?",
        str(failed.value),
    ), str(failed.value)
    assert failed.value.__cause__ is recording.error
    metadata = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert metadata["message_count"] == held


def test_messages_dds_lost_before_the_recording_are_warned_counted_and_told_at_stop(
    make_node: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A 30 Hz 1080p camera recorded 136 of 178 frames and nothing said so: the recording's
    readers had no message_lost event."""
    from pyconnect.ros import following_subscription

    # Counted where the rmw can take the event without deadlocking (not Fast DDS).
    monkeypatch.setattr(following_subscription, "_losses_deadlock", lambda: False)
    node = make_node("lossy_recorder")
    logged = WarningsLogged(node.get_logger())
    monkeypatch.setattr(node, "get_logger", lambda: logged)
    node.add_agent(conn_name="chatter", conn_type="sub", data_interface=String)
    node.add_agent(conn_name="other", conn_type="sub", data_interface=String)
    node.create_publisher(String, "chatter", 10)
    node.create_publisher(String, "other", 10)
    bag = tmp_path / "lossy"
    recording = node.record(bag)
    node.spin(run_thread=True)
    assert _wait_for(lambda: set(recording._subscriptions) == {"/chatter", "/other"})
    on_lost = message_lost_callback(recording._subscriptions["/chatter"].subscription)
    assert recording.lost == {}
    on_lost(lost(3, 3))
    on_lost(lost(5, 2))
    message_lost_callback(recording._subscriptions["/other"].subscription)(lost(1, 1))
    assert recording.lost == {"/chatter": 5, "/other": 1}
    recording.stop()  # a loss is no failure of the bag: nothing raised
    assert logged.warnings == [
        "recording /chatter: DDS lost 3 message(s) so far before they reached the recorder; "
        "they are not in the bag (the recording's end counts them all)",
        "recording /other: DDS lost 1 message(s) so far before they reached the recorder; "
        "they are not in the bag (the recording's end counts them all)",
        f"record: {bag}: DDS lost 6 message(s) (/chatter: 5, /other: 1) before they reached "
        "the recording; they are not in the bag",
    ]
    assert recording.lost == {"/chatter": 5, "/other": 1}
