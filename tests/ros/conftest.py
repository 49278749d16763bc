"""Fixtures for agent tests: nodes on their own rclpy context, shut down after each test."""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import rclpy

from pyconnect.ros.custom_node import CustomNode

EVENT_TIMEOUT = 20.0
"""Seconds to wait for anything that crosses DDS: generous, so slow machines pass."""


@pytest.fixture
def make_node(tmp_path: Path) -> Iterator[Callable[..., CustomNode]]:
    nodes: list[CustomNode] = []

    def make(name: str = "test_node", **options: Any) -> CustomNode:
        options.setdefault("args", [])
        options.setdefault("handle_signals", False)
        options.setdefault("log_dir", tmp_path / "logs")
        node = CustomNode(name, context=rclpy.Context(), **options)
        nodes.append(node)
        return node

    yield make
    for node in nodes:
        node.shutdown()


def repeat_until(event: threading.Event, action: Callable[[], object]) -> bool:
    """Do ``action`` until ``event`` is set (discovery takes a moment); False after the timeout."""
    for _ in range(int(EVENT_TIMEOUT / 0.05)):
        action()
        if event.wait(0.05):
            return True
    return False


def server_and_client(
    make_node: Callable[..., CustomNode],
    name: str,
    kind: str,
    interface: object,
    handler: Callable[..., Any],
    *,
    conn_name: str = "served",
) -> tuple[CustomNode, Any]:
    """A ``{kind}_server`` (``"service"`` or ``"action"``) of ``interface`` answering with
    ``handler`` on a node of its own, and its client on another, both spinning and connected:
    (the server's node, the client agent)."""
    server_node, client_node = make_node(f"{name}_server"), make_node(f"{name}_client")
    server_node.add_agent(
        conn_name=conn_name, conn_type=f"{kind}_server", data_interface=interface,
        response_func=handler,
    )  # fmt: skip
    client = client_node.add_agent(
        conn_name=conn_name, conn_type=f"{kind}_client", data_interface=interface,
        timeout=EVENT_TIMEOUT,
    )  # fmt: skip
    server_node.spin(run_thread=True)
    client_node.spin(run_thread=True)
    client_node.wait_until_connected(timeout=EVENT_TIMEOUT)
    return server_node, client


def wait_for_the_result_request(server_node: CustomNode, conn_name: str) -> None:
    """Until the action server ``conn_name`` has taken its client's request for a result."""
    asked = threading.Event()
    server = server_node.agents[conn_name].server  # type: ignore[attr-defined]
    assert repeat_until(asked, lambda: asked.set() if server._waiting else None)
