"""A compiled package on a live graph: pyconnect agents and a plain rclpy process, both ways.

The rclpy side runs in its own process with a bare environment (``bare_environment``); the
pyconnect side is this process, which imports the compiled package from the session prefix and
uses it with no codec or conversion code at all.
"""

from __future__ import annotations

import subprocess
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest
import rclpy

from pyconnect.ros.custom_node import CustomNode
from tests.codegen.test_compile import PEER, TIMEOUT, bare_environment

pytestmark = pytest.mark.e2e


@contextmanager
def peer(prefix: Path, mode: str) -> Iterator[subprocess.Popen[str]]:
    """Start the plain rclpy peer and wait for its READY line; stop it afterwards."""
    child = subprocess.Popen(
        [sys.executable, str(PEER), mode],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        env=bare_environment(prefix),
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


def read_lines(child: subprocess.Popen[str], prefix: str, count: int = 1) -> list[str]:
    """The first ``count`` stdout lines of ``child`` starting with ``prefix``."""
    assert child.stdout is not None
    found: list[str] = []
    for line in child.stdout:
        if line.startswith(prefix):
            found.append(line.strip())
            if len(found) == count:
                return found
    raise AssertionError(f"the peer ended without {count} {prefix!r} line(s): {found}")


def run_with_timeout(function: Callable[[], Any]) -> Any:
    outcome: list[Any] = []
    worker = threading.Thread(target=lambda: outcome.append(function()), daemon=True)
    worker.start()
    worker.join(TIMEOUT)
    assert outcome, "timed out"
    return outcome[0]


@pytest.fixture
def node(compiled_prefix: Path) -> Iterator[CustomNode]:
    made = CustomNode("pyconnect_compiled", context=rclpy.Context(), args=[], handle_signals=False)
    yield made
    made.shutdown()


def test_plain_talker_to_pyconnect_sub(compiled_prefix: Path, node: CustomNode) -> None:
    from tutorial_interfaces.msg import Num

    heard = threading.Event()
    sub = node.add_agent(
        conn_name="num", conn_type="sub", data_interface=Num, response_func=lambda _v: heard.set()
    )
    node.spin(run_thread=True)
    with peer(compiled_prefix, "talker"):
        assert heard.wait(TIMEOUT)
    assert set(sub.get()) == {"num"}


def test_pyconnect_pub_to_plain_listener(compiled_prefix: Path, node: CustomNode) -> None:
    pub = node.add_agent(
        conn_name="sphere",
        conn_type="pub",
        data_interface="tutorial_interfaces/msg/Sphere",
        time_period=0.02,
    )
    pub.send({"header": {"frame_id": "map"}, "center": {"x": 1.5}, "radius": 2.0})
    node.spin(run_thread=True)
    with peer(compiled_prefix, "listener") as child:
        assert run_with_timeout(lambda: read_lines(child, "HEARD")) == ["HEARD map 1.5 2.0"]


def test_pyconnect_client_to_plain_service(compiled_prefix: Path, node: CustomNode) -> None:
    client = node.add_agent(
        conn_name="add_three_ints",
        conn_type="service_client",
        data_interface="tutorial_interfaces/srv/AddThreeInts",
        timeout=TIMEOUT,
    )
    node.spin(run_thread=True)
    with peer(compiled_prefix, "service_server"):
        assert client.send({"a": 1, "b": 20, "c": 300}) == {"sum": 321, "isdone": True}


def test_plain_client_to_pyconnect_service(compiled_prefix: Path, node: CustomNode) -> None:
    from tutorial_interfaces.srv import AddThreeInts

    node.add_agent(
        conn_name="add_three_ints",
        conn_type="service_server",
        data_interface=AddThreeInts,
        response_func=lambda request: {"sum": 10 * (request["a"] + request["b"] + request["c"])},
    )
    node.spin(run_thread=True)
    with peer(compiled_prefix, "service_client") as child:
        assert run_with_timeout(lambda: read_lines(child, "RESPONSE")) == ["RESPONSE 60"]


def test_pyconnect_action_client_to_plain_server(compiled_prefix: Path, node: CustomNode) -> None:
    client = node.add_agent(
        conn_name="move_to",
        conn_type="action_client",
        data_interface="tutorial_interfaces/action/MoveTo",
        timeout=TIMEOUT,
    )
    node.spin(run_thread=True)
    with peer(compiled_prefix, "action_server"):
        result = client.send({"target": {"x": 1.0, "y": 2.0, "z": 3.0}})
    assert result == {"reached": True, "message": "at 1.0 2.0 3.0", "isdone": True}


def test_plain_action_client_to_pyconnect_server(compiled_prefix: Path, node: CustomNode) -> None:
    def move_to(goal: dict[str, Any]) -> Iterator[dict[str, Any]]:
        yield {"remaining": goal["speed"]}
        target = goal["target"]
        return {"reached": True, "message": f"pyconnect at {target['x']} {target['z']}"}

    node.add_agent(
        conn_name="move_to",
        conn_type="action_server",
        data_interface="tutorial_interfaces/action/MoveTo",
        response_func=move_to,
    )
    node.spin(run_thread=True)
    with peer(compiled_prefix, "action_client") as child:
        lines = run_with_timeout(lambda: read_lines(child, "RESULT"))
    # Status 4 is STATUS_SUCCEEDED.
    assert lines == ["RESULT 4 True pyconnect at 1.0 3.0"]
