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
