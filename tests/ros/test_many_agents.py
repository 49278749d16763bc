"""A node with 120 agents (the design promises 100+) connects to its mirror and runs them all."""

from __future__ import annotations

from typing import Any

from std_msgs.msg import String
from std_srvs.srv import Trigger
from test_msgs.action import Fibonacci

from .conftest import EVENT_TIMEOUT


def add_many_agents(node: Any, *, mine: str, theirs: str) -> None:
    """40 subs, 40 pubs, 10+10 service servers/clients, 5+5 action servers/clients, 10 timers.

    ``mine``/``theirs`` prefix the names this node serves and the names its mirror serves.
    """
    for index in range(40):
        node.add_agent(conn_name=f"{theirs}_topic_{index}", conn_type="sub",
                       data_interface=String, qos="latched")  # fmt: skip
        pub = node.add_agent(conn_name=f"{mine}_topic_{index}", conn_type="pub",
                             data_interface=String, qos="latched")  # fmt: skip
        pub.send(f"{mine} {index}")
    for index in range(10):
        node.add_agent(conn_name=f"{mine}_service_{index}", conn_type="service_server",
                       data_interface=Trigger,
                       response_func=lambda _request: {"success": True, "message": ""})  # fmt: skip
        node.add_agent(conn_name=f"{theirs}_service_{index}", conn_type="service_client",
                       data_interface=Trigger, timeout=EVENT_TIMEOUT)  # fmt: skip
        node.add_agent(conn_name=f"{mine}_timer_{index}", conn_type="timer", time_period=0.5,
                       response_func=lambda: None)  # fmt: skip
    for index in range(5):
        node.add_agent(conn_name=f"{mine}_action_{index}", conn_type="action_server",
                       data_interface=Fibonacci,
                       response_func=lambda _goal: {"sequence": [1]})  # fmt: skip
        node.add_agent(conn_name=f"{theirs}_action_{index}", conn_type="action_client",
                       data_interface=Fibonacci, timeout=EVENT_TIMEOUT)  # fmt: skip


def test_a_node_with_120_agents_connects_to_its_mirror_and_serves(make_node: Any) -> None:
    left = make_node("many_left")
    right = make_node("many_right")
    add_many_agents(left, mine="left", theirs="right")
    add_many_agents(right, mine="right", theirs="left")
    assert len(left.agents) == 120
    left.spin(run_thread=True)
    right.spin(run_thread=True)
    left.wait_until_connected(timeout=EVENT_TIMEOUT * 3)
    right.wait_until_connected(timeout=EVENT_TIMEOUT * 3)
    assert left.agents["right_topic_39"].get() == "right 39"
    assert left.agents["right_service_9"].send({}) == {
        "success": True,
        "message": "",
        "isdone": True,
    }
    assert left.agents["right_action_4"].send({"order": 1}) == {"sequence": [1], "isdone": True}
