"""A node with 120 agents (the design promises 100+) connects to its mirror and runs them all."""

from __future__ import annotations

from typing import Any

from bench.agents import add_many_agents

from .conftest import EVENT_TIMEOUT


def test_a_node_with_120_agents_connects_to_its_mirror_and_serves(make_node: Any) -> None:
    left = make_node("many_left")
    right = make_node("many_right")
    add_many_agents(left, mine="left", theirs="right", timeout=EVENT_TIMEOUT)
    add_many_agents(right, mine="right", theirs="left", timeout=EVENT_TIMEOUT)
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
