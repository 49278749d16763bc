"""A sensor ``sub`` agent without ``qos=`` follows its publishers' reliability (ros/qos.py)."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

import pytest
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CameraInfo, Image

from pyconnect.ros.qos import SENSOR_DATA, matching_reliability
from tests.ros.conftest import EVENT_TIMEOUT, repeat_until
from tests.ros.test_following_subscription import WarningsLogged, lost, message_lost_callback

BEST_EFFORT = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)


def frame(index: int) -> Image:
    return Image(height=1, width=1, encoding="mono8", step=1, data=bytes([index]))


def until(condition: Callable[[], bool]) -> bool:
    """Wait until ``condition`` holds (graph changes have no event to wait on)."""
    done = threading.Event()
    return repeat_until(done, lambda: done.set() if condition() else None)


def add_camera_sub(node: Any, name: str = "camera", **options: Any) -> tuple[Any, list[int]]:
    """A sub agent on ``camera`` recording the first data byte of every frame it gets."""
    heard: list[int] = []
    agent = node.add_agent(
        conn_name="camera",
        agent_name=name,
        conn_type="sub",
        data_interface=Image,
        decode_func=lambda msg: msg.data[0],
        response_func=heard.append,
        **options,
    )
    return agent, heard


def test_the_rule_is_reliable_unless_a_publisher_is_best_effort() -> None:
    class Endpoint:
        def __init__(self, reliability: ReliabilityPolicy) -> None:
            self.qos_profile = QoSProfile(depth=1, reliability=reliability)

    reliable, best_effort = ReliabilityPolicy.RELIABLE, ReliabilityPolicy.BEST_EFFORT
    assert matching_reliability([]) == reliable
    assert matching_reliability([Endpoint(reliable), Endpoint(reliable)]) == reliable
    assert matching_reliability([Endpoint(reliable), Endpoint(best_effort)]) == best_effort
    # As rmw's best available: anything but reliable (an unknown policy) is not reliable.
    unknown = ReliabilityPolicy.UNKNOWN
    assert matching_reliability([Endpoint(reliable), Endpoint(unknown)]) == best_effort


def test_a_reliable_publisher_gets_a_reliable_sub_that_hears_a_whole_burst(make_node: Any) -> None:
    node = make_node()
    driver = node.create_publisher(Image, "camera", QoSProfile(depth=10))
    sub, heard = add_camera_sub(node)
    assert sub.subscription.qos_profile.reliability == ReliabilityPolicy.RELIABLE
    node.spin(run_thread=True)
    assert repeat_until(sub._first_message, lambda: driver.publish(frame(0)))
    burst = list(range(1, 6))  # the sub's queue depth: a reliable reader keeps all of them
    all_heard = threading.Event()
    sub.response_func = lambda value: (heard.append(value), value == 5 and all_heard.set())
    for index in burst:
        driver.publish(frame(index))
    assert all_heard.wait(EVENT_TIMEOUT)
    assert [value for value in heard if value != 0] == burst
    assert sub.sensor_subscription.switch_note is None


def test_a_best_effort_publisher_first_gets_a_best_effort_sub(make_node: Any) -> None:
    node = make_node()
    node.create_publisher(Image, "camera", QoSProfile(depth=10))
    driver = node.create_publisher(Image, "camera", BEST_EFFORT)
    sub, heard = add_camera_sub(node)
    assert sub.subscription.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT
    node.spin(run_thread=True)
    assert repeat_until(sub._first_message, lambda: driver.publish(frame(7)))
    assert heard[0] == 7
    assert sub.sensor_subscription.switch_note is None


def test_a_best_effort_publisher_appearing_later_switches_the_sub(
    make_node: Any, capfd: pytest.CaptureFixture[str]
) -> None:
    node = make_node()
    sub, heard = add_camera_sub(node)
    first = sub.subscription
    assert first.qos_profile.reliability == ReliabilityPolicy.RELIABLE
    node.spin(run_thread=True)
    driver = make_node("driver").create_publisher(Image, "camera", BEST_EFFORT)
    sensor = sub.sensor_subscription
    assert sensor.switched.wait(EVENT_TIMEOUT)
    assert sensor.switch_note == (
        "agent 'camera' (sub sensor_msgs/msg/Image): a best-effort publisher appeared on "
        "/camera, so the subscription switched from reliable to best effort (a reliable reader "
        "never hears a best-effort writer); without pyconnect run's shared memory, large "
        "messages may now be lost on the way. Pass qos= to choose yourself."
    )
    assert sub.subscription is not first
    assert sub.subscription.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT
    assert repeat_until(sub._first_message, lambda: driver.publish(frame(3)))
    assert heard[0] == 3
    assert sub.get() == heard[-1]
    assert [s for s in node.subscriptions if s.topic_name == "/camera"] == [sub.subscription]
    assert capfd.readouterr().err.count(sensor.switch_note) == 1


def test_the_switch_keeps_hearing_a_reliable_publisher(make_node: Any) -> None:
    node = make_node()
    sub, heard = add_camera_sub(node)
    reliable = make_node("reliable_driver")
    reliable_driver = reliable.create_publisher(Image, "camera", QoSProfile(depth=10))
    node.spin(run_thread=True)
    assert repeat_until(sub._first_message, lambda: reliable_driver.publish(frame(1)))
    driver = make_node("driver").create_publisher(Image, "camera", BEST_EFFORT)
    assert sub.sensor_subscription.switched.wait(EVENT_TIMEOUT)
    # Once the best-effort reader has matched both publishers, the reliable one is gone.
    assert until(lambda: len([s for s in node.subscriptions if s.topic_name == "/camera"]) == 1)
    assert sub.subscription.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT
    from_both = threading.Event()
    sub.response_func = lambda value: (
        heard.append(value),
        {4, 5} <= set(heard) and from_both.set(),
    )
    assert repeat_until(
        from_both, lambda: (reliable_driver.publish(frame(4)), driver.publish(frame(5)))
    )


@pytest.mark.parametrize("qos", ["default", "sensor_data", QoSProfile(depth=3), 4])
def test_an_explicit_qos_is_never_changed(make_node: Any, qos: Any) -> None:
    node = make_node()
    explicit, _heard = add_camera_sub(node, "explicit", qos=qos)
    following, _ = add_camera_sub(node, "following")
    chosen = explicit.subscription
    reliability = chosen.qos_profile.reliability
    assert explicit.sensor_subscription is None
    node.spin(run_thread=True)
    make_node("driver").create_publisher(Image, "camera", BEST_EFFORT)
    # The node has seen the best-effort publisher once the default sub switched.
    assert following.sensor_subscription.switched.wait(EVENT_TIMEOUT)
    assert explicit.subscription is chosen
    assert chosen.qos_profile.reliability == reliability
    assert chosen in node.subscriptions
    expected = SENSOR_DATA if qos == "sensor_data" else QoSProfile(depth=10)
    assert reliability == expected.reliability


def node_with_an_action_server(make_node: Any) -> Any:
    """A node on the elastic executor (action agents keep it there)."""
    from test_msgs.action import Fibonacci

    node = make_node()
    node.add_agent(
        conn_name="fib",
        conn_type="action_server",
        data_interface=Fibonacci,
        response_func=lambda _goal: {"sequence": [1]},
    )
    return node


def test_the_switch_works_on_the_elastic_executor(make_node: Any) -> None:
    node = node_with_an_action_server(make_node)
    assert node._executor.mode == "elastic"  # a node with action agents stays on it
    sub, heard = add_camera_sub(node)
    node.spin(run_thread=True)
    driver = make_node("driver").create_publisher(Image, "camera", BEST_EFFORT)
    assert sub.sensor_subscription.switched.wait(EVENT_TIMEOUT)
    assert repeat_until(sub._first_message, lambda: driver.publish(frame(9)))
    assert heard[0] == 9
    assert sub.subscription.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT
    assert node._executor.mode == "elastic"


def test_the_switch_works_when_the_event_waits_on_the_cold_thread(make_node: Any) -> None:
    node = node_with_an_action_server(make_node)
    sub, heard = add_camera_sub(node)
    node.spin(run_thread=True)
    elastic = node._executor._elastic
    handlers = sub.subscription.event_handlers
    # Quiet for a while, the QoS event handlers leave the wait set for the cold waiter's thread.
    assert until(lambda: all(elastic.is_cold(handler) for handler in handlers))
    driver = make_node("driver").create_publisher(Image, "camera", BEST_EFFORT)
    assert sub.sensor_subscription.switched.wait(EVENT_TIMEOUT)
    assert repeat_until(sub._first_message, lambda: driver.publish(frame(8)))
    assert heard[0] == 8


SWAP = ["--ros-args", "-r", "left:=right", "-r", "right:=left"]


def test_the_switch_stays_on_the_topic_remapping_chose(make_node: Any) -> None:
    """The switch re-created the reader from its resolved name, which the node's rules remapped
    a second time: under ``left:=right right:=left`` the sub moved from /right to /left."""
    heard: list[int] = []
    node = make_node("swapped", args=SWAP)
    agent = node.add_agent(
        conn_name="left",
        conn_type="sub",
        data_interface=Image,
        decode_func=lambda msg: msg.data[0],
        response_func=heard.append,
    )
    assert agent.topic == "/right"
    node.spin(run_thread=True)
    driver = make_node("driver").create_publisher(Image, "/right", BEST_EFFORT)
    assert agent.sensor_subscription.switched.wait(EVENT_TIMEOUT)
    assert agent.subscription.topic_name == "/right"
    assert repeat_until(agent._first_message, lambda: driver.publish(frame(7)))
    assert heard[-1] == 7


LATCHED_INFO = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def test_a_late_sub_to_latched_publishers_gets_the_latched_message(make_node: Any) -> None:
    """The sensor sub followed its publishers' reliability only, always volatile: a latched
    CameraInfo sent before it joined never arrived (rmw's best-available rule hears it)."""
    driver = make_node("info_driver")
    publisher = driver.create_publisher(CameraInfo, "camera_info", LATCHED_INFO)
    publisher.publish(CameraInfo(width=640))
    driver.spin(run_thread=True)
    node = make_node("late_info")
    assert until(lambda: bool(node.get_publishers_info_by_topic("/camera_info")))
    heard = threading.Event()
    sub = node.add_agent(
        conn_name="camera_info",
        conn_type="sub",
        data_interface=CameraInfo,
        decode_func=lambda msg: msg.width,
        response_func=lambda _width: heard.set(),
    )
    assert sub.subscription.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL
    node.spin(run_thread=True)
    assert heard.wait(EVENT_TIMEOUT)
    assert sub.get() == 640


def test_a_volatile_publisher_appearing_later_switches_a_latched_sub(make_node: Any) -> None:
    """A transient-local reader never hears a volatile writer: the sub relaxes its durability
    when one appears, and says so."""
    driver = make_node("info_driver")
    driver.create_publisher(CameraInfo, "camera_info", LATCHED_INFO).publish(CameraInfo(width=1))
    node = make_node("switching_info")
    assert until(lambda: bool(node.get_publishers_info_by_topic("/camera_info")))
    sub = node.add_agent(
        conn_name="camera_info",
        conn_type="sub",
        data_interface=CameraInfo,
        decode_func=lambda msg: msg.width,
    )
    node.spin(run_thread=True)
    volatile = driver.create_publisher(CameraInfo, "camera_info", 10)
    sensor = sub.sensor_subscription
    assert sensor.switched.wait(EVENT_TIMEOUT)
    assert sensor.switch_note == (
        "agent 'camera_info' (sub sensor_msgs/msg/CameraInfo): a volatile publisher appeared on "
        "/camera_info, so the subscription switched from transient local to volatile (a "
        "transient-local reader never hears a volatile writer). Pass qos= to choose yourself."
    )
    assert sub.subscription.qos_profile.durability == DurabilityPolicy.VOLATILE
    got_two = threading.Event()
    assert repeat_until(
        got_two,
        lambda: (volatile.publish(CameraInfo(width=2)), sub.get() == 2 and got_two.set()),
    )


def test_a_switched_sub_is_watched_as_the_first_one(make_node: Any) -> None:
    """The re-created reader's callback was not wrapped by the executor's watch: a slow handler
    no longer handed the node to the elastic executor at once (a 20 Hz timer beside it stopped),
    and when the idle check did, the agent's group was not held, so a handler blocking in
    ``send()`` let the agent's next message run beside it."""
    node = make_node()
    running, release = threading.Event(), threading.Event()
    sub = node.add_agent(
        conn_name="camera",
        conn_type="sub",
        data_interface=Image,
        response_func=lambda _frame: (running.set(), release.wait(EVENT_TIMEOUT)),
    )
    node.spin(run_thread=True)
    driver = make_node("driver").create_publisher(Image, "camera", BEST_EFFORT)
    executor = node._executor
    try:
        assert sub.sensor_subscription.switched.wait(EVENT_TIMEOUT)
        assert repeat_until(running, lambda: driver.publish(frame(1)))
        # The monitor saw the handler run and moved the node, holding the agent's group.
        assert until(lambda: executor.mode == "elastic")
        assert executor._held is not None
        assert executor._held[0] is sub.callback_group
        assert not sub.callback_group.can_execute(sub.subscription)
    finally:
        release.set()


def test_a_sensor_sub_counts_the_frames_dds_lost_and_warns_once(
    make_node: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A best-effort camera sub losing frames was silent: message_lost was never registered."""
    from pyconnect.ros import following_subscription

    # Counted where the rmw can take the event without deadlocking (not Fast DDS).
    monkeypatch.setattr(following_subscription, "_losses_deadlock", lambda: False)
    node = make_node()
    logged = WarningsLogged(node.get_logger())
    monkeypatch.setattr(node, "get_logger", lambda: logged)
    node.create_publisher(Image, "camera", BEST_EFFORT)
    sub, _heard = add_camera_sub(node)
    on_lost = message_lost_callback(sub.subscription)  # registered on the real reader
    assert sub.lost_count == 0
    on_lost(lost(3, 3))
    on_lost(lost(5, 2))
    assert sub.lost_count == 5
    assert logged.warnings == [
        "agent 'camera' (sub sensor_msgs/msg/Image): DDS lost 3 message(s) on /camera so far "
        "before they reached the subscription (the agent's lost_count counts on)"
    ]
    assert "5 lost on the way" in sub.info_text()
