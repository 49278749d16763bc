"""A peer's agents: pub/sub, services, timers, connection checks and faults, all on loopback."""

from __future__ import annotations

import logging
import math
import threading
import time
from typing import Any

import numpy as np
import pytest

from pyconnect.errors import ConnectionTimeout, EncodeError, PyconnectError
from pyconnect.ros.agent_options import OptionError
from pyconnect.transport import rmw_zenoh_keys as keys
from pyconnect.transport.peer_options import KEEP_ALL_DEPTH
from pyconnect.transport.service_agents import ServiceClientAgent
from pyconnect.transport.topic_publisher import PublisherAgent
from pyconnect.transport.topic_subscriber import SubscriberAgent
from tests.transport.conftest import TIMEOUT, PeerFactory, wait_for


def connected_pair(make_peer: PeerFactory, topic: str, type_name: str, **sub_options: Any) -> Any:
    sender, receiver = make_peer("vision"), make_peer("robot")
    sub = receiver.add_agent(
        conn_name=topic, conn_type="sub", data_interface=type_name, **sub_options
    )
    pub = sender.add_agent(conn_name=topic, conn_type="pub", data_interface=type_name)
    assert wait_for(lambda: pub.subscriber_count == 1)
    return pub, sub


def test_image_arrives_as_the_same_ndarray(make_peer: PeerFactory) -> None:
    got = threading.Event()
    pub, sub = connected_pair(
        make_peer, "camera", "sensor_msgs/msg/Image", response_func=lambda _v: got.set()
    )
    image = np.random.default_rng(1).integers(0, 255, (48, 64, 3), dtype=np.uint8)
    assert pub.send(image) is True
    assert got.wait(TIMEOUT)
    received = sub.get()
    assert isinstance(received, np.ndarray)
    np.testing.assert_array_equal(received, image)


def test_joint_state_arrives_as_the_same_dict(make_peer: PeerFactory) -> None:
    got = threading.Event()
    pub, sub = connected_pair(
        make_peer, "joints", "sensor_msgs/msg/JointState", response_func=lambda _v: got.set()
    )
    joints = {"elbow": {"position": 0.5, "velocity": -1.0, "effort": 2.0}}
    pub.send(joints)
    assert got.wait(TIMEOUT)
    assert sub.get() == joints
    assert sub.message_count == 1


def test_a_raising_callback_is_reported_and_the_next_sample_handled(
    make_peer: PeerFactory, caplog: pytest.LogCaptureFixture
) -> None:
    seen: list[str] = []
    done = threading.Event()

    def on_text(text: str) -> None:
        seen.append(text)
        if text == "boom":
            raise ValueError("bad text")
        done.set()

    pub, sub = connected_pair(make_peer, "chatter", "std_msgs/msg/String", response_func=on_text)
    with caplog.at_level(logging.ERROR, logger="pyconnect.transport"):
        pub.send("boom")
        assert wait_for(lambda: sub.error_count == 1)
        pub.send("fine")
        assert done.wait(TIMEOUT)
    assert seen == ["boom", "fine"]
    assert sub.last_error == (
        "agent 'chatter' (sub std_msgs/msg/String): response_func raised ValueError: bad text"
    )
    assert "ValueError: bad text" in caplog.text


def test_a_sample_of_another_type_is_counted_and_reported_once_per_publisher(
    make_peer: PeerFactory, caplog: pytest.LogCaptureFixture
) -> None:
    sender, receiver = make_peer("talker"), make_peer("listener")
    sub = receiver.add_agent(
        conn_name="chatter", conn_type="sub", data_interface="std_msgs/msg/Int32"
    )
    pub = sender.add_agent(
        conn_name="chatter", conn_type="pub", data_interface="std_msgs/msg/String"
    )
    # The subscription listens on the String key once the graph shows this publisher.
    assert wait_for(lambda: pub.matched)
    with caplog.at_level(logging.WARNING, logger="pyconnect.transport"):
        pub.send("not a number")
        pub.send("still not")
        assert wait_for(lambda: sub.type_mismatch_count == 2)
    assert sub.message_count == 0
    assert sub.get() is None
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert warnings == [
        f"agent 'chatter' (sub std_msgs/msg/Int32) on /chatter: publisher {pub.gid.hex()}: "
        "ignored samples of std_msgs/msg/String "
        "(RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18); "
        "this subscription expects std_msgs/msg/Int32 "
        "(RIHS01_b6578ded3c58c626cfe8d1a6fb6e04f706f97e9f03d2727c9ff4e74b1cef0deb)"
    ]


def test_a_payload_over_the_limit_is_dropped_and_counted(make_peer: PeerFactory) -> None:
    sender, receiver = make_peer("vision"), make_peer("robot", max_payload_bytes=1000)
    sub = receiver.add_agent(
        conn_name="camera", conn_type="sub", data_interface="sensor_msgs/msg/Image"
    )
    pub = sender.add_agent(
        conn_name="camera", conn_type="pub", data_interface="sensor_msgs/msg/Image"
    )
    assert wait_for(lambda: pub.subscriber_count == 1)
    pub.send(np.zeros((100, 100), dtype=np.uint8))
    pub.send(np.zeros((4, 4), dtype=np.uint8))
    assert wait_for(lambda: sub.message_count == 1)
    assert sub.oversize_count == 1
    assert sub.get().shape == (4, 4)


def test_a_bad_value_raises_an_encode_error_naming_the_agent(make_peer: PeerFactory) -> None:
    peer = make_peer("vision")
    pub = peer.add_agent(conn_name="count", conn_type="pub", data_interface="std_msgs/msg/Int32")
    with pytest.raises(EncodeError) as raised:
        pub.send("three")
    assert str(raised.value).startswith("agent 'count' (pub std_msgs/msg/Int32): ")


def test_service_call_and_a_raising_handler_still_answers(make_peer: PeerFactory) -> None:
    server_peer, client_peer = make_peer("robot"), make_peer("vision")

    def handle(request: dict[str, Any]) -> dict[str, Any]:
        if not request["data"]:
            raise RuntimeError("refused")
        return {"success": True, "message": "on"}

    server_peer.add_agent(
        conn_name="enable",
        conn_type="service_server",
        data_interface="std_srvs/srv/SetBool",
        response_func=handle,
    )
    client = client_peer.add_agent(
        conn_name="enable",
        conn_type="service_client",
        data_interface="std_srvs/srv/SetBool",
        timeout=TIMEOUT,
    )
    client_peer.wait_until_connected(timeout=TIMEOUT)
    assert client.send({"data": True}) == {"success": True, "message": "on", "isdone": True}
    assert client.send({"data": False}) == {
        "success": False,
        "message": "RuntimeError: refused",
        "isdone": True,
    }
    future = client.send({"data": True}, block=False)
    assert future.result(TIMEOUT)["message"] == "on"


def test_a_call_to_a_vanished_server_fails_like_custom_node(make_peer: PeerFactory) -> None:
    server_peer, client_peer = make_peer("robot"), make_peer("vision")
    server_peer.add_agent(
        conn_name="trigger",
        conn_type="service_server",
        data_interface="std_srvs/srv/Trigger",
        response_func=lambda _r: {"success": True},
    )
    client = client_peer.add_agent(
        conn_name="trigger", conn_type="service_client", data_interface="std_srvs/srv/Trigger"
    )
    client_peer.wait_until_connected(timeout=TIMEOUT)
    server_peer.shutdown()
    assert client_peer.wait_for_graph(lambda: client.server_count == 0, time.monotonic() + TIMEOUT)
    assert client.send(None, timeout=0.5) == {
        "isdone": False,
        "error": "agent 'trigger' (service_client std_srvs/srv/Trigger): "
        "no server for /trigger within 0.5 s",
    }


def test_wait_until_connected_names_the_agents_still_waiting(make_peer: PeerFactory) -> None:
    peer = make_peer("vision")
    peer.add_agent(conn_name="scan", conn_type="sub", data_interface="sensor_msgs/msg/LaserScan")
    peer.add_agent(
        conn_name="reset", conn_type="service_client", data_interface="std_srvs/srv/Empty"
    )
    with pytest.raises(ConnectionTimeout) as raised:
        peer.wait_until_connected(timeout=0.2)
    assert str(raised.value) == (
        "peer 'vision': still waiting after 0.2 s for "
        "agent 'scan' (sub sensor_msgs/msg/LaserScan) (no publisher now), "
        "agent 'reset' (service_client std_srvs/srv/Empty) (no server now)"
    )


def test_a_vanished_publisher_is_noticed(make_peer: PeerFactory) -> None:
    pub, sub = connected_pair(make_peer, "chatter", "std_msgs/msg/String")
    pub.send("hello")
    sub.peer.wait_until_connected(timeout=TIMEOUT)
    pub.peer.shutdown()
    assert wait_for(lambda: sub.publisher_count == 0)
    with pytest.raises(ConnectionTimeout) as raised:
        sub.peer.wait_until_connected(timeout=0.1)
    assert str(raised.value) == (
        "peer 'robot': still waiting after 0.1 s for "
        "agent 'chatter' (sub std_msgs/msg/String) (no publisher now)"
    )


def test_timer_and_periodic_publisher(make_peer: PeerFactory) -> None:
    sender, receiver = make_peer("vision"), make_peer("robot")
    ticks = receiver.add_agent(
        conn_name="tick", conn_type="timer", time_period=0.01, response_func=lambda: "tock"
    )
    sub = receiver.add_agent(
        conn_name="heartbeat", conn_type="sub", data_interface="std_msgs/msg/Int32"
    )
    sender.add_agent(
        conn_name="heartbeat",
        conn_type="pub",
        data_interface="std_msgs/msg/Int32",
        time_period=0.01,
        response_func=lambda: 7,
    )
    assert wait_for(lambda: ticks.tick_count >= 3 and sub.message_count >= 3)
    assert ticks.get() == "tock"
    assert sub.get() == 7


def test_encode_and_decode_funcs_keep_the_seed_signatures(make_peer: PeerFactory) -> None:
    def encode(data: str, msg: Any) -> Any:
        msg.data = data.upper()
        return msg

    sender, receiver = make_peer("vision"), make_peer("robot")
    sub = receiver.add_agent(
        conn_name="chatter",
        conn_type="sub",
        data_interface="std_msgs/msg/String",
        decode_func=lambda msg: f"<{msg.data}>",
    )
    pub = sender.add_agent(
        conn_name="chatter",
        conn_type="pub",
        data_interface="std_msgs/msg/String",
        encode_func=encode,
    )
    assert wait_for(lambda: pub.subscriber_count == 1)
    pub.send("hi")
    assert wait_for(lambda: sub.message_count == 1)
    assert sub.get() == "<HI>"


def test_unknown_kinds_and_options_raise(make_peer: PeerFactory) -> None:
    peer = make_peer("vision")
    with pytest.raises(PyconnectError) as raised:
        peer.add_agent(conn_name="a", conn_type="subscriber", data_interface="x/msg/Y")
    assert str(raised.value) == (
        "agent 'a': conn_type 'subscriber' is not available on a peer; expected one of "
        "'sub', 'pub', 'service_client', 'service_server', 'timer', 'action_client', "
        "'action_server'"
    )


def test_add_agent_takes_a_config_dict_as_custom_node_does(make_peer: PeerFactory) -> None:
    peer = make_peer("vision")
    config = {"conn_name": "chatter", "conn_type": "pub", "data_interface": "std_msgs/msg/String"}
    agent = peer.add_agent(config)
    assert peer.agents["chatter"] is agent
    assert agent.conn_type == "pub"
    # Keywords win over the dict's keys.
    sub = peer.add_agent({**config, "conn_type": "pub"}, conn_type="sub", agent_name="heard")
    assert peer.agents["heard"] is sub
    assert sub.conn_type == "sub"


def test_add_agents_gives_shared_options_only_to_the_kinds_that_take_them(
    make_peer: PeerFactory,
) -> None:
    peer = make_peer("vision")
    configs = [
        {"conn_name": "s", "conn_type": "service_client", "data_interface": "std_srvs/srv/SetBool"},
        {"conn_name": "chatter", "conn_type": "sub", "data_interface": "std_msgs/msg/String"},
    ]
    client, sub = peer.add_agents(configs, timeout=2.0, qos=3)
    assert isinstance(client, ServiceClientAgent)
    assert client.timeout == 2.0
    assert isinstance(sub, SubscriberAgent)
    assert sub.depth == 3
    # One no kind takes on a peer is not dropped quietly.
    with pytest.raises(OptionError) as raised:
        peer.add_agents([{**configs[1], "conn_name": "other"}], do_log_msg=True)
    assert str(raised.value) == (
        "agent 'other' (sub): option 'do_log_msg' is not available on a peer: "
        "a peer writes no message logs (log from response_func)"
    )


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (
            {"conn_type": "sub", "data_interface": "std_msgs/msg/String", "time_period": 1.0},
            "agent 'b' (sub): option 'time_period' is not used by a 'sub' agent",
        ),
        (
            {"conn_type": "service_server", "data_interface": "std_srvs/srv/SetBool", "qos": 5},
            "agent 'b' (service_server): option 'qos' is not used by a 'service_server' agent",
        ),
        (
            {"conn_type": "sub", "data_interface": "std_msgs/msg/String", "tiemout": 1.0},
            "agent 'b' (sub): unknown option 'tiemout'",
        ),
        (
            {"conn_type": "pub"},
            "agent 'b' (pub): missing option 'data_interface'",
        ),
        (
            {"data_interface": "std_msgs/msg/String"},
            "agent 'b': missing option 'conn_type'",
        ),
        (
            {"conn_type": "timer", "time_period": 1.0, "response_func": print, "do_log_msg": True},
            "agent 'b' (timer): option 'do_log_msg' is not available on a peer: "
            "a peer writes no message logs (log from response_func)",
        ),
        (
            {"conn_type": "pub", "data_interface": "std_msgs/msg/String", "codec": None},
            "agent 'b' (pub): option 'codec' is not available on a peer",
        ),
        (
            {"conn_type": "sub", "data_interface": "std_msgs/msg/String", "qos": 3, "depth": 4},
            "agent 'b' (sub): give qos= or depth=, not both",
        ),
        (
            {"conn_type": "sub", "data_interface": "std_msgs/msg/String", "qos": "latched"},
            "agent 'b' (sub): qos 'latched' cannot be honoured on a peer: it keeps no cache for "
            "late joiners (zenoh-python has no publication cache)",
        ),
    ],
)
def test_a_wrong_option_raises_option_error_as_custom_node_does(
    make_peer: PeerFactory, options: dict[str, Any], message: str
) -> None:
    peer = make_peer("vision")
    with pytest.raises(OptionError) as raised:
        peer.add_agent(conn_name="b", **options)
    assert str(raised.value) == message
    assert isinstance(raised.value, TypeError)  # as CustomNode's
    assert peer.agents == {}


def _two(goal: Any, publish_feedback: Any) -> Any:
    return goal


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (
            {"conn_type": "sub", "data_interface": "std_msgs/msg/String", "raw": 0},
            "agent 'b' (sub): raw: expected bool or None, got 0",
        ),
        (
            {"conn_type": "pub", "data_interface": "std_msgs/msg/String", "only_if_subscribed": 1},
            "agent 'b' (pub): only_if_subscribed: expected bool or None, got 1",
        ),
        (
            {"conn_type": "sub", "data_interface": "std_msgs/msg/String", "response_func": "cb"},
            "agent 'b' (sub): response_func: expected a callable, got 'cb'; pass the function "
            "itself, not its name",
        ),
        (
            {"conn_type": "pub", "data_interface": "std_msgs/msg/String", "encode_func": 3},
            "agent 'b' (pub): encode_func: expected a callable, got 3",
        ),
        (
            {"conn_type": "sub", "data_interface": "std_msgs/msg/String", "response_func": dir},
            None,  # a builtin without a readable signature: accepted
        ),
        (
            {
                "conn_type": "sub",
                "data_interface": "std_msgs/msg/String",
                "response_func": lambda: None,
            },
            "agent 'b' (sub): response_func: a sub calls it with one argument (the value), but "
            "it takes no positional arguments",
        ),
        (
            {"conn_type": "timer", "time_period": 1.0, "response_func": lambda tick: None},
            "agent 'b' (timer): response_func: a timer calls it with no arguments, but it "
            "requires 'tick'",
        ),
        (
            {
                "conn_type": "pub",
                "data_interface": "std_msgs/msg/String",
                "time_period": 1.0,
                "response_func": lambda value: value,
            },
            "agent 'b' (pub): response_func: a periodic pub calls it with no arguments, but it "
            "requires 'value'",
        ),
        (
            {
                "conn_type": "service_server",
                "data_interface": "std_srvs/srv/Trigger",
                "response_func": lambda: {},
            },
            "agent 'b' (service_server): response_func: a service_server calls it with one "
            "argument (the request), but it takes no positional arguments",
        ),
        (
            {
                "conn_type": "action_server",
                "data_interface": "test_msgs/action/Fibonacci",
                "response_func": lambda: {},
            },
            "agent 'b' (action_server): response_func: an action_server calls it with one "
            "argument (the goal), but it takes no positional arguments",
        ),
        (
            {
                "conn_type": "action_server",
                "data_interface": "test_msgs/action/Fibonacci",
                "response_func": lambda goal, publish_feedback, extra: {},
            },
            "agent 'b' (action_server): response_func: an action_server calls it with two "
            "arguments (the goal and publish_feedback, as it takes a second positional "
            "parameter), but it requires 'goal', 'publish_feedback', 'extra'",
        ),
        (
            {
                "conn_type": "action_server",
                "data_interface": "test_msgs/action/Fibonacci",
                "response_func": _two,
            },
            None,  # called with the goal and publish_feedback
        ),
        (
            {
                "conn_type": "action_server",
                "data_interface": "test_msgs/action/Fibonacci",
                "response_func": _two,
                "result_timeout": -1,
            },
            "agent 'b' (action_server): result_timeout must be a finite number of seconds >= 0, "
            "got -1",
        ),
        (
            {
                "conn_type": "action_server",
                "data_interface": "test_msgs/action/Fibonacci",
                "response_func": _two,
                "result_cache_seconds": "60",
            },
            "agent 'b' (action_server): result_cache_seconds must be a finite number of "
            "seconds >= 0, got '60'",
        ),
        (
            {
                "conn_type": "action_client",
                "data_interface": "test_msgs/action/Fibonacci",
                "accepted_func": lambda: None,
            },
            "agent 'b' (action_client): accepted_func: an action_client calls it with one "
            "argument (accepted: bool), but it takes no positional arguments",
        ),
        (
            {"conn_type": "timer", "time_period": 1.0, "response_func": print, "agent_name": 5},
            "agent 'b': agent_name: expected str or None, got 5",
        ),
    ],
)
def test_a_wrong_option_value_raises_option_error_as_custom_node_does(
    make_peer: PeerFactory, options: dict[str, Any], message: str | None
) -> None:
    """CustomNode checks these values when the agent is added; a peer took them and failed
    at every message, or (result_timeout=-1) inside its action server."""
    peer = make_peer("vision")
    if message is None:
        peer.add_agent(conn_name="b", **options)
        assert list(peer.agents) == ["b"]
        return
    with pytest.raises(OptionError) as raised:
        peer.add_agent(conn_name="b", **options)
    assert str(raised.value) == message
    assert peer.agents == {}


@pytest.mark.parametrize(
    ("qos", "message"),
    [
        (
            "fast",
            "agent 'b' (pub): qos: unknown profile 'fast'; expected a QoSProfile or one of "
            "'default', 'sensor_data', 'latched'",
        ),
        (True, "agent 'b' (pub): qos: expected a QoSProfile, a name or a depth, got True"),
        (2.5, "agent 'b' (pub): qos: expected a QoSProfile, a name or a depth, got float"),
        (0, "agent 'b' (pub): qos: depth must be >= 1, got 0"),
    ],
)
def test_a_bad_qos_value_raises_naming_it(
    make_peer: PeerFactory, qos: object, message: str
) -> None:
    peer = make_peer("vision")
    with pytest.raises(PyconnectError) as raised:
        peer.add_agent(conn_name="b", conn_type="pub", data_interface="std_msgs/msg/Int32", qos=qos)
    assert str(raised.value) == message


def test_qos_sets_the_depth_of_a_sub_or_pub(make_peer: PeerFactory) -> None:
    qos = pytest.importorskip("rclpy.qos")
    peer = make_peer("vision")
    string = {"data_interface": "std_msgs/msg/String"}

    def sub_depth(name: str, value: object) -> int:
        agent = peer.add_agent(conn_name=name, conn_type="sub", qos=value, **string)
        assert isinstance(agent, SubscriberAgent)
        return agent.depth

    assert sub_depth("a", 3) == 3
    assert sub_depth("b", "sensor_data") == 5
    assert sub_depth("c", "default") == 10
    assert sub_depth("d", None) == 10
    best_effort = qos.QoSProfile(depth=7, reliability=qos.ReliabilityPolicy.BEST_EFFORT)
    assert sub_depth("e", best_effort) == 7  # reliability is not used: zenoh links are reliable
    assert sub_depth("f", qos.QoSProfile(history=qos.HistoryPolicy.KEEP_ALL)) == KEEP_ALL_DEPTH
    pub = peer.add_agent(conn_name="g", conn_type="pub", qos=3, **string)
    assert isinstance(pub, PublisherAgent)
    assert pub.token_key.endswith(f"/{keys.qos_chunk(depth=3)}")  # what ROS graphs are told
    latched = qos.QoSProfile(depth=1, durability=qos.DurabilityPolicy.TRANSIENT_LOCAL)
    with pytest.raises(OptionError) as raised:
        peer.add_agent(conn_name="h", conn_type="pub", qos=latched, **string)
    assert str(raised.value) == (
        "agent 'h' (pub): qos durability TRANSIENT_LOCAL cannot be honoured on a peer: it keeps "
        "no cache for late joiners (zenoh-python has no publication cache)"
    )


def test_with_block_and_spin_thread_shut_down(make_peer: PeerFactory) -> None:
    peer = make_peer("vision")
    stopped: list[bool] = []
    peer.stop_func = lambda: stopped.append(True)
    with peer:
        peer.spin(run_thread=True)
        assert peer.ok()
    assert not peer.ok()
    assert stopped == [True]
    with pytest.raises(PyconnectError):
        peer.spin()


def test_listen_takes_run_thread_as_custom_node_does(make_peer: PeerFactory) -> None:
    peer = make_peer("vision")
    done = threading.Event()

    def listen_here() -> None:
        peer.listen()
        done.set()

    peer.listen(run_thread=True)  # returns at once
    thread = threading.Thread(target=listen_here, daemon=True)
    thread.start()
    assert not done.is_set()
    peer.shutdown()
    assert done.wait(TIMEOUT)  # listen() blocked until the shutdown
    with pytest.raises(PyconnectError):
        peer.listen(run_thread=True)


def test_a_peer_is_not_ok_once_its_shutdown_begins(make_peer: PeerFactory) -> None:
    """Calls racing the shutdown see it before the session closes under them."""
    peer = make_peer("vision")
    seen: list[bool] = []
    peer.stop_func = lambda: seen.append(peer.ok())
    peer.shutdown()
    assert seen == [False]


def test_a_shutdown_closes_its_agents_at_once(
    make_peer: PeerFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Each close waits up to 5 s for its handler: one after another, a few blocked handlers
    kept a shutdown past a supervisor's SIGKILL."""
    peer = make_peer("vision")
    timers = [
        peer.add_agent(conn_name=f"t{n}", conn_type="timer", time_period=60.0, response_func=print)
        for n in range(4)
    ]
    # Every close waits here until all four are closing: only closes that overlap get through.
    all_closing = threading.Barrier(len(timers), timeout=5.0)
    broken: list[str] = []
    for timer in timers:
        close = timer.close

        def close_together(close: Any = close, name: str = timer.name) -> None:
            try:
                all_closing.wait()
            except threading.BrokenBarrierError:
                broken.append(name)
            close()

        monkeypatch.setattr(timer, "close", close_together)
    peer.shutdown()
    assert broken == []


def test_blocked_handlers_keep_a_shutdown_about_one_close_in_all(make_peer: PeerFactory) -> None:
    release = threading.Event()
    blocked: list[str] = []

    def block(value: str) -> None:
        blocked.append(value)
        release.wait(TIMEOUT)

    sender, receiver = make_peer("vision"), make_peer("robot")
    subs = [
        receiver.add_agent(
            conn_name=f"topic{n}",
            conn_type="sub",
            data_interface="std_msgs/msg/String",
            response_func=block,
        )
        for n in range(4)
    ]
    pubs = [
        sender.add_agent(
            conn_name=sub.conn_name, conn_type="pub", data_interface="std_msgs/msg/String"
        )
        for sub in subs
    ]
    assert wait_for(lambda: all(pub.subscriber_count == 1 for pub in pubs))
    for pub in pubs:
        pub.send(pub.conn_name)
    try:
        assert wait_for(lambda: len(blocked) == 4)
        started = time.monotonic()
        receiver.shutdown()
        took = time.monotonic() - started
    finally:
        release.set()
    # Each sub's close gives its handler 5 s: one after another they took 20 s.
    assert took < 2 * 5.0


def test_a_close_that_never_ends_holds_the_shutdown_only_until_its_deadline(
    make_peer: PeerFactory, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    from pyconnect.transport import peer as peer_module

    monkeypatch.setattr(peer_module, "AGENTS_CLOSE_SECONDS", 0.2)
    peer = make_peer("vision")
    timer = peer.add_agent(conn_name="t", conn_type="timer", time_period=60.0, response_func=print)
    close, release = timer.close, threading.Event()

    def stuck() -> None:
        release.wait(10.0)  # longer than the deadline, and long enough that it is noticed
        close()

    monkeypatch.setattr(timer, "close", stuck)
    try:
        with caplog.at_level(logging.WARNING, logger="pyconnect.transport"):
            started = time.monotonic()
            peer.shutdown()
            took = time.monotonic() - started
    finally:
        release.set()
    assert took < 5.0
    assert "peer 'vision': closing the session after 0.2 s with agents still closing: " in (
        caplog.text
    )
    assert "agent 't' (timer)" in caplog.text


def test_add_agent_is_refused_once_the_shutdown_begins(
    make_peer: PeerFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Shutdown lists the agents it closes when it begins: one added later (while a running
    goal kept the shutdown waiting) was never closed, a timer ticking on after shutdown()."""
    peer = make_peer("vision")
    timer = peer.add_agent(conn_name="t", conn_type="timer", time_period=60.0, response_func=print)
    close, closing, release = timer.close, threading.Event(), threading.Event()

    def slow_close() -> None:
        closing.set()
        release.wait(TIMEOUT)
        close()

    monkeypatch.setattr(timer, "close", slow_close)
    shutting_down = threading.Thread(target=peer.shutdown)
    shutting_down.start()
    try:
        assert closing.wait(TIMEOUT)
        with pytest.raises(PyconnectError) as raised:
            peer.add_agent(
                conn_name="late", conn_type="timer", time_period=0.01, response_func=print
            )
        assert str(raised.value) == "peer 'vision' is shut down; cannot add 'late'"
        assert "late" not in peer.agents
    finally:
        release.set()
        shutting_down.join(TIMEOUT)
        late = peer.agents.pop("late", None)
        if late is not None:  # the bug: close what the shutdown left running
            late.close()


def test_an_agent_added_while_the_shutdown_begins_is_closed_by_it(
    make_peer: PeerFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The shutdown waits for an add_agent in progress, and closes what it added."""
    from pyconnect.transport import peer as peer_module

    peer = make_peer("vision")
    checking, release = threading.Event(), threading.Event()
    check_values = peer_module.check_values

    def slow_check(conn_type: str, given: Any, where: str) -> None:
        checking.set()  # inside add_agent, holding the peer's lock
        release.wait(TIMEOUT)
        check_values(conn_type, given, where)

    monkeypatch.setattr(peer_module, "check_values", slow_check)
    added: list[Any] = []
    adding = threading.Thread(
        target=lambda: added.append(
            peer.add_agent(conn_name="t", conn_type="timer", time_period=60.0, response_func=print)
        )
    )
    adding.start()
    assert checking.wait(TIMEOUT)
    shutting_down = threading.Thread(target=peer.shutdown)
    shutting_down.start()
    time.sleep(0.2)  # the shutdown begins while the agent is being added (if not: a pass)
    release.set()
    adding.join(TIMEOUT)
    shutting_down.join(TIMEOUT)
    [timer] = added
    try:
        assert timer._stop.is_set()  # closed by the shutdown
    finally:
        timer.close()


def test_a_burst_is_not_cut_to_depth_while_the_subscription_keeps_up(
    make_peer: PeerFactory,
) -> None:
    handled: list[str] = []
    pub, sub = connected_pair(
        make_peer, "chatter", "std_msgs/msg/String", response_func=handled.append, depth=10
    )
    assert (sub.burst_samples, sub.burst_seconds) == (1000, 0.02)
    sub.burst_seconds = TIMEOUT  # "keeping up" however slow this machine is now
    for number in range(500):  # back to back: zenoh batches them, the ring takes each batch
        pub.send(f"message {number}")
    assert wait_for(lambda: sub.message_count == 500)
    assert handled == [f"message {number}" for number in range(500)]
    assert sub.dropped_count == 0


def test_only_types_without_unbounded_sequences_get_a_burst_allowance(
    make_peer: PeerFactory,
) -> None:
    peer = make_peer("vision")
    for type_name, burst in [
        ("std_msgs/msg/String", 1000),
        ("geometry_msgs/msg/PoseStamped", 1000),
        ("sensor_msgs/msg/Image", 0),
        ("sensor_msgs/msg/JointState", 0),
    ]:
        agent = peer.add_agent(
            conn_name=type_name.replace("/", "_"), conn_type="sub", data_interface=type_name
        )
        assert agent.burst_samples == burst, type_name


def test_samples_waiting_at_shutdown_are_not_handed_on(make_peer: PeerFactory) -> None:
    release = threading.Event()
    handled: list[str] = []

    def slow(value: str) -> None:
        handled.append(value)
        release.wait(TIMEOUT)

    pub, sub = connected_pair(make_peer, "chatter", "std_msgs/msg/String", response_func=slow)
    pub.send("first")
    assert wait_for(lambda: handled == ["first"])
    for number in range(50):
        pub.send(f"waiting {number}")
    closing = threading.Thread(target=sub.peer.shutdown)
    closing.start()
    assert wait_for(lambda: sub._closed)
    release.set()
    closing.join(TIMEOUT)
    assert not closing.is_alive()
    assert handled == ["first"]


def test_a_slow_subscription_keeps_the_last_depth_samples(make_peer: PeerFactory) -> None:
    release = threading.Event()
    handled: list[int] = []
    started: list[float] = []

    def slow(value: int) -> None:
        handled.append(value)
        started.append(time.monotonic())
        release.wait(TIMEOUT)

    pub, sub = connected_pair(make_peer, "count", "std_msgs/msg/Int32", response_func=slow, depth=3)
    pub.send(1)
    assert wait_for(lambda: handled == [1])
    # The first sample is in the handler; the others go to the agent's keep-last ring. A marker
    # put after them on the same link arrives after zenoh has pushed them all into the ring.
    marker = threading.Event()
    probe = sub.peer.session.declare_subscriber("probe/marker", lambda _sample: marker.set())
    probe_publisher = pub.peer.session.declare_publisher("probe/marker")
    assert wait_for(lambda: probe_publisher.matching_status.matching)
    for value in range(2, 31):
        pub.send(value)
    probe_publisher.put(b"after")
    assert marker.wait(TIMEOUT)
    probe.undeclare()
    # Busy longer than the burst window: what waits now is a backlog, not a transport burst.
    assert wait_for(lambda: time.monotonic() - started[0] > sub.burst_seconds)
    release.set()
    assert wait_for(lambda: sub.message_count == 4)
    assert handled == [1, 28, 29, 30]
    assert sub.dropped_count == 26
    assert sub.get() == 30


def test_a_malformed_reply_fails_the_call_like_any_other(make_peer: PeerFactory) -> None:
    """A reply that is not CDR of the response type: {'isdone': False, ...}, never an exception."""
    from pyconnect.transport import rmw_zenoh_keys as keys

    peer = make_peer("vision")
    client = peer.add_agent(
        conn_name="trigger",
        conn_type="service_client",
        data_interface="std_srvs/srv/Trigger",
        timeout=TIMEOUT,
    )
    queryable = peer.session.declare_queryable(
        client.key, lambda query: query.reply(client.key, b"\xff" * 12), complete=True
    )
    token = peer.session.liveliness().declare_token(
        peer.entity_token(
            kind=keys.SERVICE,
            name="/trigger",
            type_name="std_srvs/srv/Trigger",
            type_hash=client.key.rsplit("/", 1)[1],  # "RIHS01_<hex>", as in the key
            qos=keys.qos_chunk(),
        )
    )
    try:
        assert client.send() == {
            "isdone": False,
            "error": "agent 'trigger' (service_client std_srvs/srv/Trigger): could not decode "
            "the response: std_srvs/srv/Trigger_Response: unsupported CDR encapsulation ffff "
            "(expected 0001 little-endian or 0000 big-endian XCDR1)",
        }
        assert client.error_count == 1
        assert client.last_error == (
            "agent 'trigger' (service_client std_srvs/srv/Trigger): decode raised DecodeError: "
            "std_srvs/srv/Trigger_Response: unsupported CDR encapsulation ffff "
            "(expected 0001 little-endian or 0000 big-endian XCDR1)"
        )
    finally:
        token.undeclare()
        queryable.undeclare()


def test_a_sample_that_does_not_decode_is_reported_naming_the_agent_once(
    make_peer: PeerFactory, caplog: pytest.LogCaptureFixture
) -> None:
    receiver, sender = make_peer("robot"), make_peer("vision")
    sub = receiver.add_agent(
        conn_name="chatter", conn_type="sub", data_interface="std_msgs/msg/String"
    )
    not_cdr = b"\x07\x07\x00\x00\x06\x00\x00\x00hello\x00"
    with caplog.at_level(logging.ERROR, logger="pyconnect.transport"):
        # Put until one arrives: the two sessions' link may take a moment.
        assert wait_for(lambda: sender.session.put(sub.key, not_cdr) or sub.error_count > 0)
    problem = (
        "agent 'chatter' (sub std_msgs/msg/String): decode raised DecodeError: "
        "std_msgs/msg/String: unsupported CDR encapsulation 0707 "
        "(expected 0001 little-endian or 0000 big-endian XCDR1)"
    )
    assert sub.last_error == problem
    assert caplog.records[0].getMessage().splitlines()[0] == problem
    assert sub.message_count == 0


@pytest.mark.parametrize("timeout", ["2", -1, math.nan, True])
def test_wait_until_connected_refuses_a_timeout_that_is_not_one(
    make_peer: PeerFactory, timeout: object
) -> None:
    peer = make_peer("waiter")
    with pytest.raises(PyconnectError, match=r"^peer 'waiter': wait_until_connected: timeout"):
        peer.wait_until_connected(timeout)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("limit", "shown"),
    [
        ("1000000", "'1000000' (str)"),
        (-5, "-5"),
        (0, "0"),
        (True, "True (bool)"),
        (1.5, "1.5 (float)"),
    ],
)
def test_a_max_payload_that_is_not_none_or_an_int_of_at_least_one_is_refused(
    limit: object, shown: str
) -> None:
    """A str made every sample raise in the receive path; 0 or less dropped them all."""
    from pyconnect.transport import Peer

    with pytest.raises(PyconnectError) as raised:
        Peer("vision", listen=[], connect=[], max_payload_bytes=limit, handle_signals=False)  # type: ignore[arg-type]
    assert str(raised.value) == (
        f"peer 'vision': max_payload_bytes: expected None or an int >= 1, got {shown}"
    )


def test_max_payload_none_or_one_is_taken(make_peer: PeerFactory) -> None:
    assert make_peer("vision", max_payload_bytes=None).max_payload_bytes is None
    assert make_peer("robot", max_payload_bytes=1).max_payload_bytes == 1


DOMAIN_EXPECTED = "expected an int from 0 to 18446744073709551614"


@pytest.mark.parametrize(
    ("domain_id", "shown"),
    [("abc", "'abc' (str)"), (-1, "-1"), (1.5, "1.5 (float)"), (False, "False (bool)"),
     (2**64 - 1, "18446744073709551615")],
)  # fmt: skip
def test_a_domain_id_rmw_does_not_take_is_refused(domain_id: object, shown: str) -> None:
    """It went into every key and token: a domain no ROS node joins."""
    from pyconnect.errors import TransportError
    from pyconnect.transport import Peer

    with pytest.raises(TransportError) as raised:
        Peer("vision", domain_id=domain_id, listen=[], connect=[], handle_signals=False)  # type: ignore[arg-type]
    assert str(raised.value) == f"peer 'vision': domain_id: {DOMAIN_EXPECTED}, got {shown}"


@pytest.mark.parametrize("text", ["-3", "abc", "1.5", "1_0", "7x"])
def test_a_ros_domain_id_rcl_does_not_take_is_refused(
    monkeypatch: pytest.MonkeyPatch, text: str
) -> None:
    from pyconnect.errors import TransportError
    from pyconnect.transport import Peer

    monkeypatch.setenv("ROS_DOMAIN_ID", text)
    with pytest.raises(TransportError) as raised:
        Peer("vision", listen=[], connect=[], handle_signals=False)
    assert str(raised.value) == f"peer 'vision': ROS_DOMAIN_ID: {DOMAIN_EXPECTED}, got {text!r}"


@pytest.mark.parametrize(
    ("text", "domain"), [("", 0), ("42", 42), (" 7 ", 7), ("010", 8), ("0x10", 16)]
)
def test_ros_domain_id_is_read_as_rcl_reads_it(
    monkeypatch: pytest.MonkeyPatch, text: str, domain: int
) -> None:
    """rcl reads it with strtoul(text, &end, 0): "010" is octal to every ROS node."""
    from pyconnect.transport.peer import default_domain_id

    monkeypatch.setenv("ROS_DOMAIN_ID", text)
    assert default_domain_id() == domain


def test_stop_func_may_add_an_agent_to_say_goodbye_and_it_is_closed(
    make_peer: PeerFactory,
) -> None:
    """As on a CustomNode: refusing add_agent from the start of the shutdown refused this."""
    peer = make_peer("leaving")
    added: list[Any] = []

    def goodbye() -> None:
        added.append(
            peer.add_agent(
                conn_name="status", conn_type="pub", data_interface="std_msgs/msg/String"
            )
        )

    peer.stop_func = goodbye
    peer.shutdown()
    assert [agent.name for agent in added] == ["status"]
    assert not peer.ok()
    with pytest.raises(PyconnectError, match="is shut down; cannot add"):
        peer.add_agent(conn_name="late", conn_type="pub", data_interface="std_msgs/msg/String")


def test_a_stop_func_that_calls_shutdown_does_not_deadlock(make_peer: PeerFactory) -> None:
    """A stop_func shared with other clean-up code called peer.shutdown() and hung for ever."""
    peer = make_peer("twice")
    calls: list[bool] = []

    def stop() -> None:
        calls.append(True)
        peer.shutdown()

    peer.stop_func = stop
    done = threading.Thread(target=peer.shutdown, daemon=True)
    done.start()
    done.join(30)
    assert not done.is_alive()
    assert calls == [True] and not peer.ok()
