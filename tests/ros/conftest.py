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
