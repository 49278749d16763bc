"""The ROS <-> zenoh bridge: a plain rclpy node, a CustomNode bridge and a peer without rclpy,
each in its own process; an Image goes ROS -> zenoh -> (peer echoes it) -> zenoh -> ROS."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from sensor_msgs.msg import Image

from pyconnect.errors import PyconnectError
from pyconnect.ros.custom_node import CustomNode
from tests.transport.conftest import loopback_config

HERE = Path(__file__).parent
REPO = HERE.parents[1]
TIMEOUT = 60.0


def spawn(script: str, *args: str, env: dict[str, str] | None = None) -> subprocess.Popen[str]:
    process = subprocess.Popen(
        [sys.executable, str(HERE / script), *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=REPO,
        env={**os.environ, "PYTHONPATH": str(REPO), **(env or {})},
    )
    assert process.stdout is not None
    line = process.stdout.readline()
    if line.strip() != "ready":
        process.kill()
        raise AssertionError(f"{script} did not start: {line!r} {process.communicate()[1]}")
    return process


def stop(process: subprocess.Popen[str]) -> str:
    process.send_signal(signal.SIGINT)
    _out, err = process.communicate(timeout=TIMEOUT)
    assert process.returncode == 0, err
    return err


def test_an_image_crosses_ros_zenoh_and_back(locator: str, tmp_path: Path) -> None:
    bridge_config = tmp_path / "bridge.json5"
    bridge_config.write_text(loopback_config(listen=locator))
    peer_config = tmp_path / "peer.json5"
    peer_config.write_text(loopback_config(connect=locator))
    bridge = spawn("bridge_node.py", env={"ZENOH_SESSION_CONFIG_URI": str(bridge_config)})
    peer = spawn("peer_without_rclpy.py", str(peer_config), "echo-image", "/camera")

    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node("plain_camera", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    back: list[Any] = []
    got = threading.Event()

    def on_back(msg: Image) -> None:
        back.append(msg)
        got.set()

    node.create_subscription(Image, "camera_back", on_back, 10)
    publisher = node.create_publisher(Image, "camera", 10)
    pixels = np.random.default_rng(3).integers(0, 255, (30, 40, 3), dtype=np.uint8)
    msg = Image(height=30, width=40, encoding="bgr8", step=120, data=pixels.tobytes())
    msg.header.frame_id = "cam"
    # The test owns its spin loop, so the spinning ends before the executor is shut down
    # (rclpy 7.1's shutdown while another thread waits makes that thread raise).
    stopping = threading.Event()

    def spin() -> None:
        while not stopping.is_set():
            executor.spin_once(timeout_sec=0.05)

    spinner = threading.Thread(target=spin, daemon=True)
    spinner.start()
    try:
        # Resend until the round trip closes: discovery on three processes takes its time.
        deadline = time.monotonic() + 4 * TIMEOUT
        while not got.wait(0.2):
            assert bridge.poll() is None and peer.poll() is None
            assert time.monotonic() < deadline, "the image never came back"
            publisher.publish(msg)
        echoed = back[0]
        assert (echoed.height, echoed.width, echoed.encoding) == (30, 40, "bgr8")
        assert bytes(echoed.data) == pixels.tobytes()
    finally:
        stopping.set()
        spinner.join(TIMEOUT)
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
        bridge_err = stop(bridge)
        peer_err = stop(peer)
    assert "Traceback" not in bridge_err + peer_err


def test_bridge_options_are_checked() -> None:
    with CustomNode("bridge_options", handle_signals=False) as node:
        with pytest.raises(PyconnectError) as raised:
            node.add_agent(conn_name="x", conn_type="timer", transport="zenoh", time_period=1.0)
        assert str(raised.value) == (
            "agent 'x': transport='zenoh' bridges conn_type 'sub' (ROS to zenoh) or "
            "'pub' (zenoh to ROS), got 'timer'"
        )
        with pytest.raises(PyconnectError) as raised:
            node.add_agent(conn_name="x", conn_type="sub", transport="tcp", data_interface=Image)
        assert str(raised.value) == "agent 'x': unknown transport 'tcp'; expected 'zenoh'"
        with pytest.raises(PyconnectError) as raised:
            node.add_agent(
                conn_name="x",
                conn_type="sub",
                transport="zenoh",
                data_interface=Image,
                response_func=print,
            )
        assert str(raised.value) == (
            "agent 'x' (sub over zenoh): option 'response_func' does not apply to a bridged "
            "agent (it takes data_interface and qos)"
        )


def test_a_malformed_sample_from_zenoh_is_reported_not_published(
    locator: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    config = tmp_path / "bridge.json5"
    config.write_text(loopback_config(listen=locator))
    monkeypatch.setenv("ZENOH_SESSION_CONFIG_URI", str(config))
    from std_msgs.msg import String

    from pyconnect.codecs import wire

    with CustomNode("bridge_checks", handle_signals=False, context=Context()) as node:
        bridge = node.add_agent(
            conn_name="words", conn_type="pub", transport="zenoh", data_interface=String
        )
        forward = bridge.zenoh_subscriber.response_func  # what zenoh's samples go through
        forward(b"\x00\x01\x00\x00\xe8\x03\x00\x00abc")  # a length beyond the payload
        assert (bridge.forwarded_count, bridge.error_count) == (0, 1)
        assert bridge.last_error == (
            "agent 'words' (pub std_msgs/msg/String): decode raised DecodeError: "
            "std_msgs/msg/String.data: length 1000 exceeds the 3 bytes left"
        )
        forward(wire.encode("fine", "std_msgs/msg/String"))
        assert (bridge.forwarded_count, bridge.error_count) == (1, 1)


def _bridge_node(name: str, locator: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Any:
    config = tmp_path / f"{name}.json5"
    config.write_text(loopback_config(listen=locator))
    monkeypatch.setenv("ZENOH_SESSION_CONFIG_URI", str(config))
    return CustomNode(name, handle_signals=False, context=Context())


def _send_until_heard(peer_pub: Any, word: str, got: dict[str, threading.Event]) -> None:
    """Send ``word`` from a peer until the ROS side has heard it (discovery takes a moment)."""
    deadline = time.monotonic() + TIMEOUT
    while not got[word].wait(0.1):
        assert time.monotonic() < deadline, "zenoh -> ROS never delivered"
        peer_pub.send(word)


def _watch_and_talk(
    node: Any, topic: str, words: tuple[str, ...]
) -> tuple[list[str], dict[str, threading.Event], Any]:
    """A plain ROS sub on ``topic`` recording what it sees (an event per word of ``words``) and
    a plain ROS pub on it: (what was seen, the events, the pub agent)."""
    from std_msgs.msg import String

    seen: list[str] = []
    got = {word: threading.Event() for word in words}

    def on_ros(value: str) -> None:
        seen.append(value)
        if value in got:
            got[value].set()

    node.add_agent(
        conn_name=topic, agent_name="watch", conn_type="sub", data_interface=String,
        response_func=on_ros,
    )  # fmt: skip
    talker = node.add_agent(
        conn_name=topic, agent_name="talker", conn_type="pub", data_interface=String
    )
    return seen, got, talker


def test_a_topic_bridged_both_ways_by_one_node_crosses_once(
    locator: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """ROS -> zenoh -> ROS -> ... never loops: the zenoh -> ROS side skips what the bridge put
    on zenoh. A zenoh peer's message reaches ROS once too."""
    from std_msgs.msg import String

    from pyconnect.transport import Peer
    from tests.transport.conftest import _no_scouting, wait_for

    with _bridge_node("loop_bridge", locator, tmp_path, monkeypatch) as node:
        to_zenoh = node.add_agent(
            conn_name="loop", conn_type="sub", data_interface=String, transport="zenoh"
        )
        to_ros = node.add_agent(
            conn_name="loop",
            agent_name="loop_back",
            conn_type="pub",
            data_interface=String,
            transport="zenoh",
        )
        seen, got, talker = _watch_and_talk(node, "loop", ("warm", "first", "sentinel"))
        node.spin(run_thread=True)
        with Peer(
            "far", config=_no_scouting(), listen=[], connect=[locator], handle_signals=False
        ) as peer:
            on_zenoh: list[str] = []
            peer.add_agent(
                conn_name="/loop",
                agent_name="listen",
                conn_type="sub",
                data_interface="std_msgs/msg/String",
                response_func=on_zenoh.append,
            )
            far = peer.add_agent(
                conn_name="/loop", conn_type="pub", data_interface="std_msgs/msg/String"
            )
            # zenoh -> ROS works (discovery done) before anything is counted.
            _send_until_heard(far, "warm", got)
            assert wait_for(lambda: to_zenoh.zenoh_publisher.matched)
            assert wait_for(lambda: talker.publisher.get_subscription_count() >= 2)
            zenoh_side = to_ros.zenoh_subscriber
            before = zenoh_side.message_count + getattr(zenoh_side, "bridged_skipped_count", 0)
            talker.send("first")
            assert got["first"].wait(TIMEOUT)
            assert wait_for(lambda: "first" in on_zenoh)
            # The bridge's own sample came back from zenoh (handled or skipped)...
            assert wait_for(
                lambda: (
                    zenoh_side.message_count + getattr(zenoh_side, "bridged_skipped_count", 0)
                    > before
                )
            )
            # ... and what the bridge publishes on ROS arrives in order: the sentinel after any
            # copy of "first".
            far.send("sentinel")
            assert got["sentinel"].wait(TIMEOUT)
            assert (seen.count("first"), seen.count("sentinel")) == (1, 1)
            assert on_zenoh.count("first") == 1
            assert zenoh_side.bridged_skipped_count > 0


def test_a_peers_message_bridged_to_ros_does_not_come_back_to_zenoh(
    locator: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A topic bridged both ways by one node: a zenoh peer's message reaches ROS once and zenoh
    subscribers once (the ROS -> zenoh side skips what the zenoh -> ROS side just published)."""
    from std_msgs.msg import String

    from pyconnect.transport import Peer
    from tests.transport.conftest import _no_scouting, wait_for

    with _bridge_node("echo_bridge", locator, tmp_path, monkeypatch) as node:
        node.add_agent(
            conn_name="echo", agent_name="echo_in", conn_type="pub", data_interface=String,
            transport="zenoh",
        )  # fmt: skip
        to_zenoh = node.add_agent(
            conn_name="echo", conn_type="sub", data_interface=String, transport="zenoh"
        )
        seen, got, talker = _watch_and_talk(node, "echo", ("warm", "once", "sentinel"))
        node.spin(run_thread=True)
        with Peer(
            "far", config=_no_scouting(), listen=[], connect=[locator], handle_signals=False
        ) as peer:
            on_zenoh: list[str] = []
            peer.add_agent(
                conn_name="/echo", agent_name="listen", conn_type="sub",
                data_interface="std_msgs/msg/String", response_func=on_zenoh.append,
            )  # fmt: skip
            far = peer.add_agent(
                conn_name="/echo", conn_type="pub", data_interface="std_msgs/msg/String"
            )
            _send_until_heard(far, "warm", got)
            assert wait_for(lambda: to_zenoh.zenoh_publisher.matched)
            assert wait_for(lambda: talker.publisher.get_subscription_count() >= 2)
            far.send("once")
            assert got["once"].wait(TIMEOUT)
            # The bridge's ROS copy of "once" reached its ROS -> zenoh side before the
            # sentinel (one reader, in order), and what it forwards goes out in that order.
            deadline = time.monotonic() + TIMEOUT
            while "sentinel" not in on_zenoh:
                assert time.monotonic() < deadline, "ROS -> zenoh never delivered"
                talker.send("sentinel")
                time.sleep(0.1)
            assert seen.count("once") == 1
            assert on_zenoh.count("once") == 1
            assert getattr(to_zenoh, "echo_skipped_count", 0) >= 1


def test_a_sensor_bridge_follows_its_publishers(
    locator: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A sensor 'sub' bridge subscribes as a 'sub' agent does: reliable while its publishers
    are (a best-effort reader loses large frames of a reliable camera)."""
    from rclpy.qos import ReliabilityPolicy

    with _bridge_node("qos_bridge", locator, tmp_path, monkeypatch) as node:
        camera = node.add_agent(
            conn_name="cam", conn_type="sub", data_interface=Image, transport="zenoh"
        )
        assert getattr(camera, "sensor_subscription", None) is not None
        assert camera.subscription.qos_profile.reliability == ReliabilityPolicy.RELIABLE


def test_the_depth_of_qos_reaches_the_zenoh_side(
    locator: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from rclpy.qos import HistoryPolicy, QoSProfile
    from std_msgs.msg import String

    with _bridge_node("depth_bridge", locator, tmp_path, monkeypatch) as node:
        small = node.add_agent(
            conn_name="map", conn_type="sub", data_interface=String, transport="zenoh", qos=7
        )
        assert small.zenoh_publisher.token_key.endswith("/::,7:,:,:,,")
        commands = node.add_agent(
            conn_name="cmds",
            conn_type="pub",
            data_interface=String,
            transport="zenoh",
            qos=QoSProfile(depth=2000, history=HistoryPolicy.KEEP_LAST),
        )
        assert commands.zenoh_subscriber.depth == 2000
        assert commands.zenoh_subscriber.token_key.endswith("/::,2000:,:,:,,")


def test_a_topic_bridged_both_ways_by_two_processes_crosses_once(
    locator: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Here ROS -> zenoh, another process zenoh -> ROS: that one skips what this one bridged
    (it knows the GID from this bridge's liveliness token)."""
    from std_msgs.msg import String

    from pyconnect.transport import Peer
    from tests.transport.conftest import _no_scouting, free_port, wait_for

    far_locator = f"tcp/127.0.0.1:{free_port()}"
    far_config = tmp_path / "far.json5"
    far_config.write_text(loopback_config(listen=far_locator, connect=locator))
    far_bridge = spawn(
        "bridge_loop_node.py", "loop2", env={"ZENOH_SESSION_CONFIG_URI": str(far_config)}
    )
    lines: list[str] = []

    def read() -> None:
        assert far_bridge.stdout is not None
        for line in far_bridge.stdout:
            lines.append(line.strip())

    threading.Thread(target=read, daemon=True).start()

    try:
        with _bridge_node("near_bridge", locator, tmp_path, monkeypatch) as node:
            node.add_agent(
                conn_name="loop2", conn_type="sub", data_interface=String, transport="zenoh"
            )
            seen, got, talker = _watch_and_talk(node, "loop2", ("first", "sentinel"))
            node.spin(run_thread=True)
            # ROS -> zenoh reaches the other process before anything is counted.
            deadline = time.monotonic() + TIMEOUT
            while "value warm" not in lines:
                assert far_bridge.poll() is None
                assert time.monotonic() < deadline, "ROS -> zenoh never reached the far bridge"
                talker.send("warm")
                time.sleep(0.1)
            talker.send("first")
            assert got["first"].wait(TIMEOUT)
            # The far bridge's session has "first" queued: the sentinel is handled after it.
            assert wait_for(lambda: "value first" in lines)
            with Peer(
                "far",
                config=_no_scouting(),
                listen=[],
                connect=[far_locator],
                handle_signals=False,
            ) as peer:
                far = peer.add_agent(
                    conn_name="/loop2", conn_type="pub", data_interface="std_msgs/msg/String"
                )
                # What the far bridge publishes on ROS arrives in order: after any copy of 'first'.
                _send_until_heard(far, "sentinel", got)
            assert seen.count("first") == 1
    finally:
        err = stop(far_bridge)
    assert "Traceback" not in err


def test_what_a_node_published_on_ros_is_skipped_once_and_only_for_a_while(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from rclpy.qos import QoSProfile

    from pyconnect.ros import bridge_echo

    def hears(_qos: QoSProfile) -> bool:
        return True

    qos = QoSProfile(depth=10)
    recent = bridge_echo.RecentlyPublished()
    recent.published("/chat", b"unwatched", qos)  # no ROS -> zenoh agent: nothing to skip
    recent.watch("/chat", hears)
    assert not recent.came_back("/chat", b"unwatched")
    recent.published("/chat", b"hello", qos)
    recent.published("/chat", b"hello", qos)
    assert not recent.came_back("/other", b"hello")
    assert [recent.came_back("/chat", b"hello") for _ in range(3)] == [True, True, False]
    monkeypatch.setattr(bridge_echo, "ECHO_SECONDS", -1.0)  # every record expired at once
    recent.published("/chat", b"late", qos)
    assert not recent.came_back("/chat", b"late")
    recent.unwatch("/chat", hears)
    recent.published("/chat", b"hello", qos)
    assert not recent.came_back("/chat", b"hello")


def test_what_the_nodes_reader_cannot_hear_is_not_waited_for() -> None:
    """A best-effort bridge publisher and a reliable reader on one node: the copy never comes
    back, and its record made the reader skip another publisher's message of the same bytes."""
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    from pyconnect.ros.bridge_echo import RecentlyPublished, qos_compatible

    reliable = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
    best_effort = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    recent = RecentlyPublished()
    recent.watch("/chat", lambda qos: qos_compatible(qos, reliable))
    recent.published("/chat", b"hello", best_effort)
    assert not recent.came_back("/chat", b"hello")  # another node's "hello" goes on to zenoh
    recent.published("/chat", b"hello", reliable)
    assert recent.came_back("/chat", b"hello")
    assert qos_compatible(reliable, best_effort)
    assert not qos_compatible(reliable, latched)  # volatile publisher, transient-local reader
    assert qos_compatible(latched, latched)
