"""pub and sub agents: registry codecs, user functions, headers, periods, gating, errors."""

from __future__ import annotations

import threading
from typing import Any

import pytest
from geometry_msgs.msg import Twist
from sensor_msgs.msg import Image
from std_msgs.msg import Header, String

from pyconnect.codecs import Stamped
from pyconnect.errors import EncodeError, PyconnectError
from pyconnect.utils import dict2str, str2dict

from .conftest import EVENT_TIMEOUT, repeat_until
from .test_following_subscription import WarningsLogged, lost, message_lost_callback


def test_string_round_trip_with_registry_codec(make_node: Any) -> None:
    node = make_node()
    got: list[str] = []
    arrived = threading.Event()
    sub = node.add_agent(
        conn_name="chatter",
        conn_type="sub",
        data_interface=String,
        response_func=lambda value: (got.append(value), arrived.set()),
    )
    pub = node.add_agent(
        conn_name="chatter", agent_name="chatter_out", conn_type="pub", data_interface=String
    )
    assert sub.get() is None
    node.spin(run_thread=True)
    assert repeat_until(arrived, lambda: pub.send("hello"))
    assert got[0] == "hello"
    assert sub.get() == "hello"
    assert pub.get() == "hello"
    assert sub.message_count >= 1


def test_seed_functions_keep_their_signatures(make_node: Any) -> None:
    node = make_node()
    arrived = threading.Event()
    seen: list[Any] = []

    def encode(data: dict[str, Any], msg: String) -> String:
        msg.data = dict2str(data)
        return msg

    def decode(msg: String) -> dict[str, Any]:
        return str2dict(msg.data)  # type: ignore[no-any-return]

    node.add_agent(
        conn_name="command",
        conn_type="sub",
        data_interface=String,
        decode_func=decode,
        response_func=lambda value: (seen.append(value), arrived.set()),
    )
    pub = node.add_agent(
        conn_name="command",
        agent_name="command_out",
        conn_type="pub",
        data_interface=String,
        encode_func=encode,
    )
    node.spin(run_thread=True)
    assert repeat_until(arrived, lambda: pub.send({"cmd": "forward", "speed": 0.5}))
    assert seen[0] == {"cmd": "forward", "speed": 0.5}


def test_twist_natural_value(make_node: Any) -> None:
    node = make_node()
    arrived = threading.Event()
    sub = node.add_agent(
        conn_name="cmd_vel",
        conn_type="sub",
        data_interface=Twist,
        response_func=lambda _value: arrived.set(),
    )
    pub = node.add_agent(
        conn_name="cmd_vel", agent_name="cmd_out", conn_type="pub", data_interface=Twist
    )
    node.spin(run_thread=True)
    assert repeat_until(arrived, lambda: pub.send(((0.2, 0.0, 0.0), (0.0, 0.0, 0.5))))
    assert sub.get() == ((0.2, 0.0, 0.0), (0.0, 0.0, 0.5))


def test_periodic_pub_repeats_last_value_or_polls_response_func(make_node: Any) -> None:
    node = make_node()
    values: list[str] = []
    three = threading.Event()

    def on_value(value: str) -> None:
        values.append(value)
        if len(values) >= 3:
            three.set()

    node.add_agent(conn_name="beat", conn_type="sub", data_interface=String, response_func=on_value)
    counter = iter(range(1000))
    node.add_agent(
        conn_name="beat",
        agent_name="beat_out",
        conn_type="pub",
        data_interface=String,
        time_period=0.02,
        response_func=lambda: f"tick {next(counter)}",
    )
    node.spin(run_thread=True)
    assert three.wait(EVENT_TIMEOUT)
    numbers = [int(value.split()[1]) for value in values]
    assert numbers == sorted(numbers)


def test_header_gets_node_stamp_and_frame_id_unless_stamped(make_node: Any) -> None:
    node = make_node()
    received: list[Image] = []
    arrived = threading.Event()
    node.add_agent(
        conn_name="camera",
        conn_type="sub",
        data_interface=Image,
        decode_func=lambda msg: msg,
        response_func=lambda msg: (received.append(msg), arrived.set()),
    )
    pub = node.add_agent(
        conn_name="camera",
        agent_name="camera_out",
        conn_type="pub",
        data_interface=Image,
        frame_id="camera_link",
    )
    node.spin(run_thread=True)
    frame = __import__("numpy").zeros((2, 3), dtype="uint8")
    assert repeat_until(arrived, lambda: pub.send(frame))
    header = received[0].header
    assert header.frame_id == "camera_link"
    assert header.stamp.sec > 0
    arrived.clear()
    received.clear()
    assert repeat_until(arrived, lambda: pub.send(Stamped(frame, 1_500_000_000, "other")))
    header = received[-1].header
    assert (header.stamp.sec, header.stamp.nanosec, header.frame_id) == (1, 500_000_000, "other")


def test_only_if_subscribed_skips_work_while_nobody_listens(make_node: Any) -> None:
    node = make_node()
    calls: list[int] = []
    pub = node.add_agent(
        conn_name="lonely",
        conn_type="pub",
        data_interface=String,
        only_if_subscribed=True,
        time_period=0.01,
        response_func=lambda: calls.append(1) or "frame",
    )
    assert pub.subscriber_count == 0
    assert pub.send("x") is False
    assert pub.sent_count == 0
    arrived = threading.Event()
    node.add_agent(
        conn_name="lonely",
        agent_name="listener",
        conn_type="sub",
        data_interface=String,
        response_func=lambda _value: arrived.set(),
    )
    before = len(calls)
    assert before == 0
    node.spin(run_thread=True)
    assert arrived.wait(EVENT_TIMEOUT)
    assert pub.subscriber_count == 1
    assert len(calls) >= 1


def test_send_rejected_value_names_the_agent(make_node: Any) -> None:
    node = make_node()
    pub = node.add_agent(conn_name="cmd_vel", conn_type="pub", data_interface=Twist)
    with pytest.raises(EncodeError) as caught:
        pub.send("fast")
    assert str(caught.value).startswith("agent 'cmd_vel' (pub geometry_msgs/msg/Twist): ")


def test_encode_func_raising_names_the_agent(make_node: Any) -> None:
    node = make_node()

    def broken(_data: object, _msg: String) -> String:
        raise KeyError("speed")

    pub = node.add_agent(
        conn_name="command", conn_type="pub", data_interface=String, encode_func=broken
    )
    with pytest.raises(EncodeError) as caught:
        pub.send({"cmd": "go"})
    assert str(caught.value) == (
        "agent 'command' (pub std_msgs/msg/String): encode_func raised KeyError for "
        "{'cmd': 'go'}: 'speed'"
    )


def test_send_on_a_sub_is_an_error(make_node: Any) -> None:
    node = make_node()
    sub = node.add_agent(conn_name="chatter", conn_type="sub", data_interface=String)
    with pytest.raises(PyconnectError) as caught:
        sub.send("x")
    assert str(caught.value) == (
        "agent 'chatter' (sub std_msgs/msg/String): send() is not available on a 'sub' agent"
    )


def test_bad_message_and_raising_response_func_do_not_stop_the_executor(make_node: Any) -> None:
    node = make_node()
    good = threading.Event()
    handled: list[str] = []

    def decode(msg: String) -> str:
        if msg.data == "bad":
            raise ValueError("cannot read 'bad'")
        return str(msg.data)

    def respond(value: str) -> None:
        handled.append(value)
        if value == "boom":
            raise RuntimeError("response failed")
        if value == "good":
            good.set()

    sub = node.add_agent(
        conn_name="mixed",
        conn_type="sub",
        data_interface=String,
        decode_func=decode,
        response_func=respond,
        qos="default",
    )
    pub = node.add_agent(
        conn_name="mixed", agent_name="out", conn_type="pub", data_interface=String, qos=10
    )
    node.spin(run_thread=True)
    matched = threading.Event()
    assert repeat_until(matched, lambda: matched.set() if pub.subscriber_count else None)
    # Matched and reliable: all three arrive, in order.
    for word in ("bad", "boom", "good"):
        pub.send(word)
    assert good.wait(EVENT_TIMEOUT)
    assert sub.get() == "good"
    assert handled == ["boom", "good"]
    assert sub.error_count == 2
    assert sub.last_error is not None and "response failed" in sub.last_error


def test_decode_error_is_reported_with_agent_name(make_node: Any) -> None:
    node = make_node()
    failed = threading.Event()

    def decode(_msg: String) -> str:
        failed.set()
        raise ValueError("unreadable")

    sub = node.add_agent(
        conn_name="bad", conn_type="sub", data_interface=String, decode_func=decode
    )
    pub = node.add_agent(conn_name="bad", agent_name="out", conn_type="pub", data_interface=String)
    node.spin(run_thread=True)
    assert repeat_until(failed, lambda: pub.send("x"))
    assert sub.get() is None
    assert sub.last_error == (
        "agent 'bad' (sub std_msgs/msg/String): decode raised DecodeError: ValueError: unreadable"
    )


def test_header_message_passes_through_as_message(make_node: Any) -> None:
    node = make_node()
    pub = node.add_agent(conn_name="h", conn_type="pub", data_interface=Header)
    assert pub.send(Header(frame_id="map")) is True


def test_stamped_sub_keeps_the_header(make_node: Any) -> None:
    node = make_node()
    arrived = threading.Event()
    sub = node.add_agent(
        conn_name="camera",
        conn_type="sub",
        data_interface=Image,
        stamped=True,
        response_func=lambda _value: arrived.set(),
    )
    pub = node.add_agent(
        conn_name="camera", agent_name="out", conn_type="pub", data_interface=Image
    )
    node.spin(run_thread=True)
    frame = __import__("numpy").full((2, 2), 7, dtype="uint8")
    assert repeat_until(arrived, lambda: pub.send(Stamped(frame, 3_000_000_007, "cam")))
    value = sub.get()
    assert (value.stamp_ns, value.frame_id) == (3_000_000_007, "cam")
    assert value.value.tolist() == [[7, 7], [7, 7]]


def test_stamped_sub_of_a_type_without_a_header_is_refused_when_added(make_node: Any) -> None:
    """It was accepted, then every message was dropped with a DecodeError."""
    from pyconnect.ros.agent_options import OptionError

    node = make_node()
    with pytest.raises(OptionError) as refused:
        node.add_agent(conn_name="chat", conn_type="sub", data_interface=String, stamped=True)
    assert str(refused.value) == (
        "agent 'chat' (sub std_msgs/msg/String): stamped=True needs a type with a "
        "std_msgs/Header, and std_msgs/msg/String has none"
    )
    assert node.agents == {}
    assert node.get_subscriber_names_and_types_by_node(node.get_name(), "/") == []
    # A Header itself is its own header, as decode_stamped finds it.
    node.add_agent(conn_name="header", conn_type="sub", data_interface=Header, stamped=True)


def test_codec_option_replaces_the_registry_codec_for_that_agent(make_node: Any) -> None:
    import numpy as np

    from pyconnect.codecs.image import ImageCodec

    node = make_node()
    received: list[Any] = []
    arrived = threading.Event()

    def on_raw(msg: Any) -> None:
        received.append(msg)
        arrived.set()

    # The sub keeps the raw message (decode_func) to see what the pub's codec produced.
    node.add_agent(
        conn_name="camera", conn_type="sub", data_interface=Image, decode_func=lambda m: m,
        response_func=on_raw, qos="default",
    )  # fmt: skip
    pub = node.add_agent(
        conn_name="camera", agent_name="out", conn_type="pub", data_interface=Image,
        codec=ImageCodec(encoding="rgb8"), qos="default",
    )  # fmt: skip
    node.spin(run_thread=True)
    pixels = np.arange(2 * 3 * 3, dtype=np.uint8).reshape(2, 3, 3)
    assert repeat_until(arrived, lambda: pub.send(pixels))
    assert received[0].encoding == "rgb8"
    assert bytes(received[0].data) == pixels.tobytes()
    with pytest.raises(PyconnectError) as raised:
        node.add_agent(conn_name="x", conn_type="pub", data_interface=Image, codec="rgb8")
    assert str(raised.value) == (
        "agent 'x' (pub sensor_msgs/msg/Image): codec: expected a codec with msg_type, lossless, "
        "encode and decode, got str"
    )


def test_periodic_pub_hands_encode_func_none_until_a_value_is_sent(make_node: Any) -> None:
    node = make_node()
    given: list[Any] = []
    heard: list[str] = []
    sent_one = threading.Event()

    def encode(data: Any, msg: String) -> String:
        given.append(data)
        msg.data = "fresh" if data is None else data
        return msg

    node.add_agent(
        conn_name="beat", conn_type="sub", data_interface=String,
        response_func=lambda value: (heard.append(value), sent_one.set()),
    )  # fmt: skip
    pub = node.add_agent(
        conn_name="beat", agent_name="out", conn_type="pub", data_interface=String,
        encode_func=encode, time_period=0.01,
    )  # fmt: skip
    node.spin(run_thread=True)
    assert sent_one.wait(EVENT_TIMEOUT)
    assert heard[0] == "fresh"
    assert given[0] is None
    pub.send("chosen")
    repeated = threading.Event()
    assert repeat_until(repeated, lambda: repeated.set() if heard[-1] == "chosen" else None)
    # After a send() the period repeats that value.
    count = len(given)
    more = threading.Event()
    assert repeat_until(more, lambda: more.set() if len(given) > count + 2 else None)
    assert set(given[count:]) == {"chosen"}


def test_periodic_pub_skips_the_periods_whose_response_func_returns_none(make_node: Any) -> None:
    """README (pub): with ``time_period``, a ``None`` from ``response_func`` publishes nothing
    that period (not an empty message, not the last value again)."""
    node = make_node()
    heard: list[str] = []
    three = threading.Event()

    def on_value(value: str) -> None:
        heard.append(value)
        if len(heard) == 3:
            three.set()

    node.add_agent(conn_name="beat", conn_type="sub", data_interface=String, response_func=on_value)
    go, idle, finished = threading.Event(), threading.Event(), threading.Event()
    script: list[str | None] = ["a", None, "b", None, None, "c"]
    trailing = 0

    def next_value() -> str | None:
        nonlocal trailing
        if not go.is_set():
            idle.set()
            return None
        if script:
            return script.pop(0)
        trailing += 1
        if trailing == 3:
            finished.set()
        return None

    pub = node.add_agent(
        conn_name="beat", agent_name="beat_out", conn_type="pub", data_interface=String,
        time_period=0.01, response_func=next_value,
    )  # fmt: skip
    node.spin(run_thread=True)
    matched = threading.Event()
    assert repeat_until(matched, lambda: matched.set() if pub.subscriber_count == 1 else None)
    assert idle.wait(EVENT_TIMEOUT)
    assert pub.sent_count == 0  # every period so far returned None
    go.set()
    assert finished.wait(EVENT_TIMEOUT)
    assert three.wait(EVENT_TIMEOUT)
    assert pub.sent_count == 3
    assert heard == ["a", "b", "c"]
    assert pub.error_count == 0


def test_periodic_pub_without_functions_waits_for_send_then_repeats_it(make_node: Any) -> None:
    """README (pub): a pub with ``time_period`` and neither ``response_func`` nor
    ``encode_func`` publishes nothing until its first ``send()``, then that value every
    period."""
    node = make_node()
    heard: list[str] = []
    repeated = threading.Event()

    def on_value(value: str) -> None:
        heard.append(value)
        if len(heard) >= 4:
            repeated.set()

    node.add_agent(conn_name="echo", conn_type="sub", data_interface=String, response_func=on_value)
    pub = node.add_agent(
        conn_name="echo", agent_name="echo_out", conn_type="pub", data_interface=String,
        time_period=0.01,
    )  # fmt: skip
    # A timer of the same period on the same node: once it ticked 5 times, so did the pub's.
    ticks = 0
    ticked = threading.Event()

    def tick() -> None:
        nonlocal ticks
        ticks += 1
        if ticks >= 5:
            ticked.set()

    node.add_agent(conn_name="clock", conn_type="timer", time_period=0.01, response_func=tick)
    node.spin(run_thread=True)
    matched = threading.Event()
    assert repeat_until(matched, lambda: matched.set() if pub.subscriber_count == 1 else None)
    assert ticked.wait(EVENT_TIMEOUT)
    assert (pub.sent_count, heard, pub.error_count) == (0, [], 0)
    assert pub.send("x") is True
    assert repeated.wait(EVENT_TIMEOUT)
    assert set(heard) == {"x"}
    assert pub.sent_count >= 4
    assert pub.error_count == 0


@pytest.mark.parametrize("timeout", [1e10, -1.0, float("nan"), "soon"])
def test_wait_for_message_refuses_a_timeout_no_wait_can_take(make_node: Any, timeout: Any) -> None:
    """1e10 s raised OverflowError from threading, a str a TypeError: said like every timeout."""
    sub = make_node("waiter").add_agent(conn_name="chat", conn_type="sub", data_interface=String)
    with pytest.raises(PyconnectError, match=r"^agent 'chat' \(sub .*\): wait_for_message: "):
        sub.wait_for_message(timeout)


def test_a_sub_counts_the_messages_dds_lost_and_warns_once(
    make_node: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Messages DDS lost before they reached a sub agent were lost silently: its subscription
    had no message_lost event."""
    from pyconnect.ros import following_subscription

    # Counted where the rmw can take the event without deadlocking (not Fast DDS).
    monkeypatch.setattr(following_subscription, "_losses_deadlock", lambda: False)
    node = make_node()
    logged = WarningsLogged(node.get_logger())
    monkeypatch.setattr(node, "get_logger", lambda: logged)
    sub = node.add_agent(conn_name="chatter", conn_type="sub", data_interface=String)
    on_lost = message_lost_callback(sub.subscription)  # registered on the real subscription
    assert sub.lost_count == 0
    on_lost(lost(0, 0))
    assert logged.warnings == []
    on_lost(lost(4, 4))
    on_lost(lost(6, 2))
    assert sub.lost_count == 6
    assert logged.warnings == [
        "agent 'chatter' (sub std_msgs/msg/String): DDS lost 4 message(s) on /chatter so far "
        "before they reached the subscription (the agent's lost_count counts on)"
    ]
    assert "6 lost on the way" in sub.info_text()


def test_a_pub_whose_timer_fails_leaves_no_publisher_behind(
    make_node: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    node = make_node()

    def refuse(*_args: Any, **_kwargs: Any) -> Any:
        raise RuntimeError("no timer today")

    # The step after the publisher's creation fails (as rclpy's refusal of a period does).
    monkeypatch.setattr(node.ros_node, "create_timer", refuse)
    with pytest.raises(RuntimeError, match="no timer today"):
        node.add_agent(conn_name="ghost", conn_type="pub", data_interface=String, time_period=0.1)
    monkeypatch.undo()
    assert "ghost" not in node.agents
    assert node.ros_node.count_publishers("/ghost") == 0


def test_on_fast_dds_no_message_lost_event_is_registered(make_node: Any) -> None:
    """Fast DDS deadlocks when the event is taken while its listener reports a loss (a 1 kHz
    stream froze the executor for good): there, subscriptions take no such event at all."""
    from rclpy.event_handler import QoSSubscriptionEventType
    from rclpy.utilities import get_rmw_implementation_identifier

    if not get_rmw_implementation_identifier().startswith("rmw_fastrtps"):
        pytest.skip("the deadlock is Fast DDS's")
    node = make_node()
    sub = node.add_agent(conn_name="chatter", conn_type="sub", data_interface=String)
    kind = QoSSubscriptionEventType.RCL_SUBSCRIPTION_MESSAGE_LOST
    assert [h for h in sub.subscription.event_handlers if h.event_type == kind] == []
