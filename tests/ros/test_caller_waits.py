"""A blocking ``send()`` waits on the caller's thread but never runs other agents' work there.

A wait that spun the node on the caller's thread could pick up a long action goal (or a slow
subscription callback) of the same node and run it inline: the caller then stayed inside that
callback and its own timeout was never checked. Each test here makes that other work block on
an event the test sets only after ``send()`` returned, so the defect fails the assertions (the
work runs on the main thread, is released by its own bounded wait, not by the test).
"""

from __future__ import annotations

import threading
from typing import Any

from std_msgs.msg import String
from std_srvs.srv import SetBool
from test_msgs.action import Fibonacci

from .conftest import EVENT_TIMEOUT

TIMEOUT_ERROR = (
    "agent 'fib_client' (action_client test_msgs/action/Fibonacci): "
    "no result within 0.5 s (goal canceled)"
)


class BlockingWork:
    """Work that blocks until ``release`` is set; remembers its thread and how it ended."""

    def __init__(self) -> None:
        self.started = threading.Event()
        self.release = threading.Event()
        self.ended = threading.Event()
        self.threads: list[threading.Thread] = []
        self.released_by_test: list[bool] = []

    def run(self) -> None:
        self.threads.append(threading.current_thread())
        self.started.set()
        # Bounded, so the defect fails the test instead of hanging the suite.
        self.released_by_test.append(self.release.wait(EVENT_TIMEOUT))
        self.ended.set()

    def check_ran_elsewhere(self) -> None:
        self.release.set()
        assert self.ended.wait(EVENT_TIMEOUT)
        assert self.released_by_test == [True]
        assert threading.main_thread() not in self.threads


def _action_pair(node: Any, work: BlockingWork) -> Any:
    def blocks(goal: dict[str, Any]) -> dict[str, Any]:
        work.run()
        return {"sequence": [goal["order"]]}

    node.add_agent(
        conn_name="fib", conn_type="action_server", data_interface=Fibonacci, response_func=blocks
    )
    return node.add_agent(
        conn_name="fib", agent_name="fib_client", conn_type="action_client",
        data_interface=Fibonacci, timeout=EVENT_TIMEOUT,
    )  # fmt: skip


def test_send_on_a_node_nobody_spins_leaves_the_goal_to_an_executor_thread(
    make_node: Any,
) -> None:
    node = make_node()
    work = BlockingWork()
    client = _action_pair(node, work)
    # Nothing spins the node: the wait itself must get the goal executed, elsewhere.
    result = client.send({"order": 1}, timeout=0.5)
    assert result == {"isdone": False, "error": TIMEOUT_ERROR}
    work.check_ran_elsewhere()


def test_send_right_after_spin_in_a_thread_never_runs_the_goal_inline(make_node: Any) -> None:
    node = make_node()
    work = BlockingWork()
    client = _action_pair(node, work)
    node.spin(run_thread=True)
    # At once, while the spin thread may still be starting the executor.
    result = client.send({"order": 1}, timeout=0.5)
    assert result == {"isdone": False, "error": TIMEOUT_ERROR}
    work.check_ran_elsewhere()


def test_service_calls_on_a_node_nobody_spins_leave_a_slow_subscriber_alone(
    make_node: Any,
) -> None:
    node = make_node()
    work = BlockingWork()
    node.add_agent(
        conn_name="chatter", conn_type="sub", data_interface=String,
        response_func=lambda _text: None if work.started.is_set() else work.run(),
    )  # fmt: skip
    publisher = node.add_agent(
        conn_name="chatter", agent_name="chatter_pub", conn_type="pub", data_interface=String
    )
    node.add_agent(
        conn_name="toggle", conn_type="service_server", data_interface=SetBool,
        response_func=lambda request: {"success": request["data"], "message": "ok"},
    )  # fmt: skip
    client = node.add_agent(
        conn_name="toggle", agent_name="toggle_client", conn_type="service_client",
        data_interface=SetBool, timeout=EVENT_TIMEOUT,
    )  # fmt: skip
    # Messages keep coming while the main thread calls: a caller-spun wait would take one.
    chatter = threading.Thread(
        target=lambda: [publisher.send("busy") for _ in iter(lambda: work.started.wait(0.01), True)]
    )
    chatter.start()
    try:
        for _ in range(int(EVENT_TIMEOUT / 0.01)):
            assert client.send({"data": True}) == {"success": True, "message": "ok", "isdone": True}
            if work.started.is_set():
                break
        assert work.started.is_set()
        # The slow subscriber still runs; a call is answered all the same.
        assert client.send({"data": True}) == {"success": True, "message": "ok", "isdone": True}
    finally:
        work.release.set()
        chatter.join()
    work.check_ran_elsewhere()
