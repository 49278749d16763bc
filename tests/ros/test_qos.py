"""``qos=`` on a CustomNode agent: a profile, a name, or a depth rmw can take."""

from __future__ import annotations

from typing import Any

import pytest
from std_msgs.msg import String

from pyconnect.errors import PyconnectError
from pyconnect.ros.qos import MAX_DEPTH, resolve_qos


@pytest.mark.parametrize("depth", [1, 10, MAX_DEPTH])
def test_an_int_is_the_depth_of_a_default_profile(depth: int) -> None:
    assert resolve_qos(depth, msg_type="std_msgs/msg/String", publisher=True).depth == depth


@pytest.mark.parametrize(
    ("depth", "problem"),
    [
        (0, "qos: depth must be >= 1, got 0"),
        (-1, "qos: depth must be >= 1, got -1"),
        (2**31, "qos: depth must be <= 2147483647, got 2147483648"),
        (2**40, "qos: depth must be <= 2147483647, got 1099511627776"),
        (True, "qos: expected a QoSProfile, a name or a depth, got True"),
    ],
)
def test_a_depth_rmw_cannot_take_is_refused(depth: int, problem: str) -> None:
    with pytest.raises(PyconnectError) as caught:
        resolve_qos(depth, msg_type="std_msgs/msg/String", publisher=True)
    assert str(caught.value) == problem


@pytest.mark.parametrize("kind", ["pub", "sub"])
@pytest.mark.parametrize("depth", [0, -1, 2**40])
def test_an_agent_with_a_wrong_depth_is_refused_naming_it(
    make_node: Any, kind: str, depth: int
) -> None:
    """rclpy said it its own way (a warning and SYSTEM_DEFAULT for 0, an RCLError for -1, a
    pybind TypeError for 2**40), naming no agent."""
    node = make_node()
    handler = {"response_func": print} if kind == "sub" else {}
    with pytest.raises(PyconnectError) as caught:
        node.add_agent(
            conn_name="chat", conn_type=kind, data_interface=String, qos=depth, **handler
        )
    bound = ">= 1" if depth < 1 else f"<= {MAX_DEPTH}"
    assert str(caught.value) == f"agent 'chat' ({kind}): qos: depth must be {bound}, got {depth}"
    assert node.agents == {}
