"""pyconnect agents talk to plain rclpy programs in other processes, both ways, no codecs given."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest
import rclpy
from std_msgs.msg import String
from std_srvs.srv import SetBool
from test_msgs.action import Fibonacci

from pyconnect.ros.custom_node import CustomNode

pytestmark = pytest.mark.e2e

PEER = Path(__file__).with_name("plain_rclpy_peer.py")
TIMEOUT = 30.0


@contextmanager
def peer(mode: str) -> Iterator[subprocess.Popen[str]]:
    """Start the plain rclpy peer and wait for its READY line; stop it afterwards."""
    child = subprocess.Popen(
        [sys.executable, str(PEER), mode],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    try:
        assert child.stdout is not None
        assert child.stdout.readline().strip() == "READY"
        yield child
    finally:
        if child.poll() is None:
            child.terminate()
        try:
            child.wait(TIMEOUT)
        except subprocess.TimeoutExpired:
            child.kill()
            child.wait()
        if child.stdout is not None:
            child.stdout.close()


@pytest.fixture
def node() -> Iterator[CustomNode]:
    made = CustomNode("pyconnect_side", context=rclpy.Context(), args=[], handle_signals=False)
    yield made
    made.shutdown()


def read_line(child: subprocess.Popen[str], prefix: str) -> str:
    """The first stdout line of ``child`` that starts with ``prefix`` (the child ends by itself)."""
    assert child.stdout is not None
    for line in child.stdout:
        if line.startswith(prefix):
            return line.strip()
    raise AssertionError(f"the peer ended without a {prefix!r} line")


def run_with_timeout(function: Callable[[], Any]) -> Any:
    outcome: list[Any] = []
    worker = threading.Thread(target=lambda: outcome.append(function()), daemon=True)
    worker.start()
    worker.join(TIMEOUT)
    assert outcome, "timed out"
    return outcome[0]


def test_plain_talker_to_pyconnect_sub(node: CustomNode) -> None:
    heard = threading.Event()
    sub = node.add_agent(
        conn_name="chatter",
        conn_type="sub",
        data_interface=String,
        response_func=lambda _value: heard.set(),
    )
    node.spin(run_thread=True)
    with peer("talker"):
        assert heard.wait(TIMEOUT)
    assert sub.get().startswith("hello ")


def test_pyconnect_pub_to_plain_listener(node: CustomNode) -> None:
    pub = node.add_agent(
        conn_name="chatter", conn_type="pub", data_interface=String, time_period=0.02
    )
    pub.send("from pyconnect")
    node.spin(run_thread=True)
    with peer("listener") as child:
        assert run_with_timeout(lambda: read_line(child, "HEARD")) == "HEARD from pyconnect"


def test_pyconnect_client_to_plain_service(node: CustomNode) -> None:
    client = node.add_agent(
        conn_name="enable", conn_type="service_client", data_interface=SetBool, timeout=TIMEOUT
    )
    node.spin(run_thread=True)
    with peer("service_server"):
        assert client.send({"data": True}) == {
            "success": True,
            "message": "plain rclpy got True",
            "isdone": True,
        }


def test_plain_client_to_pyconnect_service(node: CustomNode) -> None:
    node.add_agent(
        conn_name="enable",
        conn_type="service_server",
        data_interface=SetBool,
        response_func=lambda request: {"success": not request["data"], "message": "pyconnect"},
    )
    node.spin(run_thread=True)
    with peer("service_client") as child:
        assert run_with_timeout(lambda: read_line(child, "RESPONSE")) == "RESPONSE False pyconnect"


def test_pyconnect_action_client_to_plain_server(node: CustomNode) -> None:
    client = node.add_agent(
        conn_name="fibonacci", conn_type="action_client", data_interface=Fibonacci, timeout=TIMEOUT
    )
    node.spin(run_thread=True)
    with peer("action_server"):
        result = client.send({"order": 5})
    assert result == {"sequence": [0, 1, 1, 2, 3, 5, 8], "isdone": True}


def test_plain_action_client_to_pyconnect_server(node: CustomNode) -> None:
    def fibonacci(goal: dict[str, Any]) -> Iterator[dict[str, Any]]:
        sequence = [0, 1]
        for _ in range(goal["order"]):
            sequence.append(sequence[-1] + sequence[-2])
            yield {"sequence": list(sequence)}
        return {"sequence": sequence}

    node.add_agent(
        conn_name="fibonacci",
        conn_type="action_server",
        data_interface=Fibonacci,
        response_func=fibonacci,
    )
    node.spin(run_thread=True)
    with peer("action_client") as child:
        line = run_with_timeout(lambda: read_line(child, "RESULT"))
    # Status 4 is STATUS_SUCCEEDED.
    assert line == "RESULT 4 [0, 1, 1, 2, 3, 5, 8, 13]"
