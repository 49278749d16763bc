"""The abort-reason topic travels beside its action, however the action's name is written."""

from __future__ import annotations

import threading
from typing import Any

import pytest
from rclpy.action import ActionServer
from test_msgs.action import Fibonacci

from pyconnect.ros.abort_reasons import abort_reason_topic

from .conftest import EVENT_TIMEOUT, repeat_until

# rclpy's action classes expand an action's name but do not remap it (measured with the
# Jazzy wheel): these rules must move neither the action nor its reason topic.
REMAPPING = ["--ros-args", "-r", "fib:=fibonacci", "-r", "/robot1/act:=/moved"]


def _fails(_goal: dict[str, Any]) -> dict[str, Any]:
    raise ValueError("the reason")


@pytest.mark.parametrize("action_name", ["fib", "act", "~/act", "/abs/x", "{node}/y"])
def test_the_reason_topic_is_named_like_the_actions_own_topics(
    make_node: Any, action_name: str
) -> None:
    node = make_node("names", namespace="robot1", cli_args=REMAPPING)
    ros_node = node.ros_node
    server = ActionServer(ros_node, Fibonacci, action_name, lambda _handle: Fibonacci.Result())
    try:
        seen = threading.Event()
        statuses: list[str] = []

        def look() -> None:
            names = ros_node.get_topic_names_and_types()
            statuses[:] = [name for name, _types in names if name.endswith("/_action/status")]
            if statuses:
                seen.set()

        assert repeat_until(seen, look)
        topic = abort_reason_topic(ros_node, action_name)
        assert [topic.removesuffix("/abort_reason") + "/status"] == statuses
    finally:
        server.destroy()


@pytest.mark.parametrize("remapped", ["server", "client"])
def test_a_client_gets_the_abort_text_when_a_node_has_remapping_rules(
    make_node: Any, remapped: str
) -> None:
    server_args = REMAPPING if remapped == "server" else None
    client_args = REMAPPING if remapped == "client" else None
    server_node = make_node("remap_server", namespace="robot1", cli_args=server_args)
    client_node = make_node("remap_client", namespace="robot1", cli_args=client_args)
    server_node.add_agent(
        conn_name="fib", conn_type="action_server", data_interface=Fibonacci, response_func=_fails
    )
    client = client_node.add_agent(
        conn_name="fib", conn_type="action_client", data_interface=Fibonacci,
        timeout=EVENT_TIMEOUT,
    )  # fmt: skip
    server_node.spin(run_thread=True)
    client_node.spin(run_thread=True)
    assert client.send({"order": 1}) == {
        "sequence": [],
        "isdone": False,
        "error": "agent 'fib' (action_client test_msgs/action/Fibonacci): "
        "goal aborted by the server: ValueError: the reason",
    }
