"""rclpy#1123: a response that arrives before its request is recorded must not be lost."""

from __future__ import annotations

import threading
from typing import Any

from test_msgs.action import Fibonacci

from tests.ros.conftest import EVENT_TIMEOUT


class SlowToRecord:
    """A client handle whose goal requests are answered before rclpy records them.

    After sending, it waits until the executor thread has taken the response (or the timeout),
    which is exactly the interleaving rclpy#1123 describes. (The agent asks for results from
    the executor thread, inside the goal response's callback: no race there.)
    """

    def __init__(self, handle: Any) -> None:
        self._handle = handle
        self.taken = threading.Event()
        self.waited: list[bool] = []

    def __getattr__(self, name: str) -> Any:
        return getattr(self._handle, name)

    def __enter__(self) -> Any:
        return self._handle.__enter__()

    def __exit__(self, *exc: object) -> Any:
        return self._handle.__exit__(*exc)

    def send_goal_request(self, request: Any) -> Any:
        sequence = self._handle.send_goal_request(request)
        self.waited.append(self.taken.wait(EVENT_TIMEOUT))
        return sequence

    def take_goal_response(self, response_type: Any) -> Any:
        taken = self._handle.take_goal_response(response_type)
        if taken is not None and taken[0] is not None:
            self.taken.set()
        return taken


def test_a_response_faster_than_its_bookkeeping_still_arrives(make_node: Any) -> None:
    node = make_node()
    node.add_agent(conn_name="fast", conn_type="action_server", data_interface=Fibonacci,
                   response_func=lambda goal: {"sequence": [goal["order"]]})  # fmt: skip
    client = node.add_agent(conn_name="fast", agent_name="fast_client",
                            conn_type="action_client", data_interface=Fibonacci,
                            timeout=EVENT_TIMEOUT)  # fmt: skip
    node.spin(run_thread=True)
    node.wait_until_connected(timeout=EVENT_TIMEOUT)
    handle = SlowToRecord(client.client._client_handle)
    client.client._client_handle = handle

    assert client.send({"order": 7}) == {"sequence": [7], "isdone": True}
    # The goal response was taken while its request was still being recorded.
    assert handle.waited == [True]


class QueuedFeedback:
    """A client handle with feedback messages waiting (as after a burst) and nothing else."""

    def __init__(self, handle: Any, waiting: list[Any]) -> None:
        self._handle = handle
        self.waiting = waiting

    def __getattr__(self, name: str) -> Any:
        return getattr(self._handle, name)

    def take_feedback(self, _message_type: Any) -> Any:
        return self.waiting.pop(0) if self.waiting else None


def test_every_waiting_feedback_is_taken_in_one_wake_up(make_node: Any) -> None:
    """rclpy takes one feedback per wake-up and forgets a goal's callback once its result is
    handled: a burst just before the result lost all but the first few."""
    import asyncio

    from unique_identifier_msgs.msg import UUID

    node = make_node()
    agent = node.add_agent(conn_name="burst", conn_type="action_client", data_interface=Fibonacci)
    client = agent.client
    goal_id = bytes(range(16))
    burst = [
        Fibonacci.Impl.FeedbackMessage(
            goal_id=UUID(uuid=list(goal_id)), feedback=Fibonacci.Feedback(sequence=[n])
        )
        for n in range(5)
    ]
    seen: list[list[int]] = []
    client._feedback_callbacks[goal_id] = lambda message: seen.append(
        list(message.feedback.sequence)
    )
    real = client._client_handle
    client._client_handle = QueuedFeedback(real, list(burst))
    try:
        client._is_feedback_ready = True
        client._is_status_ready = client._is_goal_response_ready = False
        client._is_cancel_response_ready = client._is_result_response_ready = False
        taken = client.take_data()
    finally:
        client._client_handle = real
    asyncio.run(client.execute(taken))
    assert seen == [[0], [1], [2], [3], [4]]
