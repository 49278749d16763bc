"""action_server and action_client agents: feedback, cancel, abort with text, futures."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from typing import Any

from test_msgs.action import Fibonacci, NestedMessage

from .conftest import EVENT_TIMEOUT


def fibonacci(goal: dict[str, Any]) -> Iterator[dict[str, Any]]:
    sequence = [0, 1]
    for _ in range(goal["order"]):
        sequence.append(sequence[-1] + sequence[-2])
        yield {"sequence": list(sequence)}
    return {"sequence": sequence}


def _pair(node: Any, handler: Any, interface: Any = Fibonacci) -> Any:
    node.add_agent(
        conn_name="fib", conn_type="action_server", data_interface=interface, response_func=handler
    )
    client = node.add_agent(
        conn_name="fib",
        agent_name="fib_client",
        conn_type="action_client",
        data_interface=interface,
        timeout=EVENT_TIMEOUT,
    )
    node.spin(run_thread=True)
    return client


def test_generator_result_and_feedback(make_node: Any) -> None:
    node = make_node()
    client = _pair(node, fibonacci)
    feedback: list[Any] = []
    result = client.send({"order": 5}, feedback_func=feedback.append)
    assert result == {"sequence": [0, 1, 1, 2, 3, 5, 8], "isdone": True}
    # Feedback travels on a topic beside the result service: all of it may not beat the result.
    assert all(item["sequence"][:2] == [0, 1] for item in feedback)


def test_plain_function_result_via_future(make_node: Any) -> None:
    node = make_node()
    client = _pair(node, lambda goal: {"sequence": [goal["order"]] * 2})
    future = client.send({"order": 7}, block=False)
    assert future.result(EVENT_TIMEOUT) == {"sequence": [7, 7], "isdone": True}


def test_cancel_closes_the_generator_and_ends_canceled(make_node: Any) -> None:
    node = make_node()
    started = threading.Event()
    release = threading.Event()
    closed = threading.Event()

    def slow(goal: dict[str, Any]) -> Iterator[dict[str, Any]]:
        try:
            started.set()
            while not release.wait(0.01):
                yield {"sequence": [1]}
            return {"sequence": [2]}
        finally:
            closed.set()

    client = _pair(node, slow)
    future = client.send({"order": 1}, block=False)
    assert started.wait(EVENT_TIMEOUT)
    assert client.cancel() == 1
    result = future.result(EVENT_TIMEOUT)
    release.set()
    assert closed.is_set()
    assert result["isdone"] is False
    assert result["error"] == (
        "agent 'fib_client' (action_client test_msgs/action/Fibonacci): goal canceled"
    )


def test_raising_handler_aborts_with_text_when_result_has_no_string_field(make_node: Any) -> None:
    node = make_node()

    def broken(_goal: dict[str, Any]) -> dict[str, Any]:
        raise RuntimeError("arm collision")

    client = _pair(node, broken)
    result = client.send({"order": 1})
    assert result == {
        "sequence": [],
        "isdone": False,
        "error": "agent 'fib_client' (action_client test_msgs/action/Fibonacci): "
        "goal aborted by the server: RuntimeError: arm collision",
    }
    assert node.agents["fib"].last_error == (
        "agent 'fib' (action_server test_msgs/action/Fibonacci): response_func raised "
        "RuntimeError: arm collision"
    )


def test_next_goal_works_after_an_abort(make_node: Any) -> None:
    node = make_node()
    calls: list[int] = []

    def sometimes(goal: dict[str, Any]) -> dict[str, Any]:
        calls.append(goal["order"])
        if goal["order"] == 0:
            raise ValueError("zero")
        return {"sequence": [goal["order"]]}

    client = _pair(node, sometimes)
    assert client.send({"order": 0})["isdone"] is False
    assert client.send({"order": 4}) == {"sequence": [4], "isdone": True}


def test_timeout_cancels_and_reports(make_node: Any) -> None:
    node = make_node()
    release = threading.Event()

    def waits(_goal: dict[str, Any]) -> Iterator[None]:
        while not release.wait(0.01):
            yield None
        return None

    client = _pair(node, waits)
    client.send({"order": 1}, timeout=EVENT_TIMEOUT, block=False)  # warms discovery up
    result = client.send({"order": 1}, timeout=0.3)
    release.set()
    assert result == {
        "isdone": False,
        "error": "agent 'fib_client' (action_client test_msgs/action/Fibonacci): "
        "no result within 0.3 s (goal canceled)",
    }


def test_nested_message_action_round_trip(make_node: Any) -> None:
    node = make_node()
    client = _pair(
        node,
        lambda goal: {"nested_field": goal["nested_field"]},
        interface=NestedMessage,
    )
    result = client.send({"nested_field": {"bool_value": True, "int8_value": 3}})
    assert result["isdone"] is True
    assert result["nested_field"]["int8_value"] == 3
    assert result["nested_field"]["bool_value"] is True


def test_expired_goal_result_is_still_answered(make_node: Any) -> None:
    from rclpy.action import ActionClient

    node = make_node()
    server = node.add_agent(
        conn_name="quick",
        conn_type="action_server",
        data_interface=Fibonacci,
        response_func=lambda goal: {"sequence": [goal["order"], 42]},
        result_timeout=0.01,
    )
    node.spin(run_thread=True)
    client = ActionClient(node.ros_node, Fibonacci, "quick")
    assert client.wait_for_server(timeout_sec=EVENT_TIMEOUT)
    accepted = threading.Event()
    goal_future = client.send_goal_async(Fibonacci.Goal(order=9))
    goal_future.add_done_callback(lambda _future: accepted.set())
    assert accepted.wait(EVENT_TIMEOUT)
    expired = threading.Event()
    # The goal finishes and leaves the server's goal list; its result must stay available.
    for _ in range(int(EVENT_TIMEOUT / 0.01)):
        if server.goal_count == 1 and not server.server._goal_handles:
            expired.set()
            break
        expired.wait(0.01)
    assert expired.is_set()
    answered = threading.Event()
    result_future = goal_future.result().get_result_async()
    result_future.add_done_callback(lambda _future: answered.set())
    assert answered.wait(EVENT_TIMEOUT)
    response = result_future.result()
    assert response.status == 4  # STATUS_SUCCEEDED
    assert list(response.result.sequence) == [9, 42]
    client.destroy()
