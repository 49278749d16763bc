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
