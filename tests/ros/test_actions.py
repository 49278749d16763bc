"""action_server and action_client agents: feedback, cancel, abort with text, futures."""

from __future__ import annotations

import asyncio
import contextlib
import math
import sys
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from std_srvs.srv import Empty
from test_msgs.action import Fibonacci, NestedMessage

from pyconnect.errors import PyconnectError
from pyconnect.ros import (
    action_client_agent,
    action_server_agent,
    node_shutdown,
    retaining_action_server,
)

from .conftest import EVENT_TIMEOUT, server_and_client, wait_for_the_result_request
from .manual_clock import loop_in_a_thread, manual_clock_loop, run_on


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
        # Bounded, so a regression fails instead of hanging the suite (test_caller_waits pins
        # that a blocking send() never runs a goal on the caller's thread).
        for _ in range(int(EVENT_TIMEOUT / 0.01)):
            if release.wait(0.01):
                break
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


def test_publish_feedback_from_a_worker_thread(make_node: Any) -> None:
    node = make_node()
    seen_cancel: list[bool] = []
    feedback: list[Any] = []
    got_all = threading.Event()

    def long_task(goal: dict[str, Any], publish_feedback: Any) -> dict[str, Any]:
        # A library reporting progress from its own thread.
        def work() -> None:
            for step in range(goal["order"]):
                publish_feedback({"sequence": [step]})

        worker = threading.Thread(target=work)
        worker.start()
        worker.join()
        # rclpy's client drops feedback that comes after the result: finish once it arrived.
        got_all.wait(EVENT_TIMEOUT)
        seen_cancel.append(publish_feedback.cancel_requested)
        return {"sequence": [publish_feedback.published]}

    def on_feedback(value: Any) -> None:
        feedback.append(value["sequence"][0])
        if len(feedback) == 4:
            got_all.set()

    client = _pair(node, long_task)
    result = client.send({"order": 4}, feedback_func=on_feedback)
    assert result == {"sequence": [4], "isdone": True}
    assert seen_cancel == [False]
    assert feedback == [0, 1, 2, 3]


def test_publish_feedback_after_the_goal_raises(make_node: Any) -> None:
    node = make_node()
    kept: list[Any] = []
    client = _pair(node, lambda goal, publish_feedback: kept.append(publish_feedback))
    assert client.send({"order": 1})["isdone"] is True
    with pytest.raises(PyconnectError) as caught:
        kept[0]({"sequence": [1]})
    assert str(caught.value) == "publish_feedback: the goal has already finished"


def test_a_generator_handler_may_use_publish_feedback_while_it_runs(make_node: Any) -> None:
    """The generator's body runs after the handler call returned the generator object: its
    publish_feedback stays open until the generator has ended (else the goal aborts)."""
    node = make_node()
    published: list[int] = []

    def both_ways(goal: dict[str, Any], publish_feedback: Any) -> Iterator[dict[str, Any]]:
        publish_feedback({"sequence": [0]})  # e.g. from a library's progress callback
        yield {"sequence": [1]}
        published.append(publish_feedback.published)
        return {"sequence": [0, 1]}

    client = _pair(node, both_ways)
    assert client.send({"order": 1}) == {"sequence": [0, 1], "isdone": True}
    assert published == [1]


def test_sys_exit_in_a_handler_aborts_the_goal_and_shuts_the_server_down(make_node: Any) -> None:
    """rclpy's Task, which runs the goal, lets a ``SystemExit`` end the executor's thread: the
    goal stayed open and the node kept running without it."""
    server = make_node()

    def finish(_goal: dict[str, Any]) -> dict[str, Any]:
        sys.exit("mission complete")

    server.add_agent(
        conn_name="fib", conn_type="action_server", data_interface=Fibonacci, response_func=finish
    )
    server.spin(run_thread=True)
    client = make_node().add_agent(
        conn_name="fib", conn_type="action_client", data_interface=Fibonacci, timeout=EVENT_TIMEOUT
    )
    client.node.spin(run_thread=True)
    result = client.send({"order": 1})
    assert result["isdone"] is False
    assert result["error"].endswith("goal aborted by the server: SystemExit: mission complete")
    assert server.wait_for_shutdown(EVENT_TIMEOUT)


def test_client_callbacks_get_acceptance_feedback_and_what_send_returns(make_node: Any) -> None:
    node = make_node()
    accepted: list[bool] = []
    results: list[Any] = []
    feedback: list[Any] = []
    two_results = threading.Event()
    feedback_seen = threading.Event()

    def task(goal: dict[str, Any], publish_feedback: Any) -> dict[str, Any]:
        publish_feedback({"sequence": [goal["order"]]})
        feedback_seen.wait(EVENT_TIMEOUT)  # rclpy drops feedback that comes after the result
        return {"sequence": [0, goal["order"]]}

    node.add_agent(
        conn_name="fib", conn_type="action_server", data_interface=Fibonacci, response_func=task
    )

    def on_result(result: Any) -> None:
        results.append(result)
        if len(results) == 2:
            two_results.set()

    client = node.add_agent(
        conn_name="fib", agent_name="fib_client", conn_type="action_client",
        data_interface=Fibonacci, timeout=EVENT_TIMEOUT, response_func=on_result,
        accepted_func=accepted.append,
        feedback_func=lambda value: (feedback.append(value), feedback_seen.set()),
    )  # fmt: skip
    node.spin(run_thread=True)
    returned = client.send({"order": 2})
    future_value = client.send({"order": 3}, block=False).result(EVENT_TIMEOUT)
    assert two_results.wait(EVENT_TIMEOUT)
    assert results == [returned, future_value]
    assert returned == {"sequence": [0, 2], "isdone": True}
    assert accepted == [True, True]
    assert feedback[0] == {"sequence": [2]}


def test_accepted_func_hears_a_rejection(make_node: Any) -> None:
    from rclpy.action import ActionServer, GoalResponse

    node = make_node()
    server = ActionServer(
        node, Fibonacci, "picky", lambda handle: Fibonacci.Result(),
        goal_callback=lambda _goal: GoalResponse.REJECT,
    )  # fmt: skip
    accepted: list[bool] = []
    results: list[Any] = []
    client = node.add_agent(
        conn_name="picky", conn_type="action_client", data_interface=Fibonacci,
        timeout=EVENT_TIMEOUT, accepted_func=accepted.append, response_func=results.append,
    )  # fmt: skip
    node.spin(run_thread=True)
    result = client.send({"order": 1})
    assert result == {
        "isdone": False,
        "error": "agent 'picky' (action_client test_msgs/action/Fibonacci): "
        "goal rejected by the server",
    }
    assert accepted == [False]
    assert results == [result]
    server.destroy()


def test_finished_goals_leave_the_status_list(make_node: Any) -> None:
    """README (Actions stay fast): a finished goal leaves the status list (after 0.05 s, not
    rclpy's 900 s), so every status message stays short however many goals ran. Goals run one
    after another, each once the server has dropped the one before (waited for, not timed):
    then every status message lists only the goal in flight."""
    from action_msgs.msg import GoalStatus, GoalStatusArray
    from rclpy.qos import DurabilityPolicy, QoSProfile

    node = make_node()
    client = _pair(node, lambda goal: {"sequence": [goal["order"]]})
    server = node.agents["fib"]
    lock = threading.Lock()
    listed: list[list[bytes]] = []  # the goal ids of each status message, in arrival order
    succeeded: list[bytes] = []
    status_arrived = threading.Event()

    def on_status(message: GoalStatusArray) -> None:
        with lock:
            listed.append([bytes(status.goal_info.goal_id.uuid) for status in message.status_list])
            for status in message.status_list:
                goal_id = bytes(status.goal_info.goal_id.uuid)
                if status.status == GoalStatus.STATUS_SUCCEEDED and goal_id not in succeeded:
                    succeeded.append(goal_id)
        status_arrived.set()

    # rcl_action publishes the status reliable and transient local.
    node.ros_node.create_subscription(
        GoalStatusArray, "fib/_action/status", on_status,
        QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL),
    )  # fmt: skip

    def wait_for(condition: Any) -> bool:
        """Until ``condition()`` holds: woken by each status message, else every 10 ms (the
        server drops a goal without publishing anything)."""
        deadline = time.monotonic() + EVENT_TIMEOUT
        while True:
            status_arrived.clear()
            with lock:
                if condition():
                    return True
            if time.monotonic() > deadline:
                return False
            status_arrived.wait(0.01)

    for order in range(6):
        assert client.send({"order": order}) == {"sequence": [order], "isdone": True}
        # Its last status message (SUCCEEDED) reaches the subscription.
        assert wait_for(lambda count=order + 1: len(succeeded) == count), listed
        # The server drops the goal: rclpy would keep it, and list it in every later status.
        assert wait_for(lambda: not server.server._goal_handles), f"goal {order} still kept"
    with lock:
        assert max(len(ids) for ids in listed) == 1, listed
        # Each later goal's status messages list it alone: its predecessors are gone.
        for goal_id in succeeded[1:]:
            assert [goal_id] in listed


def test_a_goal_finishing_during_shutdown_still_sends_its_result(
    make_node: Any, monkeypatch: Any
) -> None:
    """rclpy sends a result from an executor task: shutdown, which has stopped the executor
    by the time the goal ends, sends it instead."""
    started, release = threading.Event(), threading.Event()

    def goal(_goal: dict[str, Any]) -> dict[str, Any]:
        started.set()
        release.wait(EVENT_TIMEOUT)
        return {"sequence": [1, 2, 3]}

    server_node, client = server_and_client(
        make_node, "finishing", "action", Fibonacci, goal, conn_name="fib"
    )
    stop = server_node._executor.stop

    def stop_then_release() -> None:
        stop()
        release.set()  # the goal ends after the executor stopped

    monkeypatch.setattr(server_node._executor, "stop", stop_then_release)
    try:
        result = client.send({"order": 3}, block=False)
        assert started.wait(EVENT_TIMEOUT)
        wait_for_the_result_request(server_node, "fib")
        server_node.shutdown()
    finally:
        release.set()
    assert result.result(EVENT_TIMEOUT * 2) == {"sequence": [1, 2, 3], "isdone": True}


def test_a_handler_that_shuts_its_node_down_still_sends_its_result(
    make_node: Any, monkeypatch: Any
) -> None:
    """A "stop" action: the handler calls node.shutdown() and returns at once. Its client asks
    for the result only once it has the acceptance, which may come after shutdown looked for
    result requests: shutdown waits for the request of every goal it keeps. Here the client
    asks only once shutdown has begun to look (a few rounds: the old code lost most)."""
    # No timing in the test: shutdown waits as long as the request takes to come.
    monkeypatch.setattr(retaining_action_server, "TAKE_FOR_SECONDS", EVENT_TIMEOUT)
    for round_ in range(3):
        assert _stop_action_round(make_node, monkeypatch, f"stop{round_}") == {
            "sequence": [7],
            "isdone": True,
        }


def _stop_action_round(make_node: Any, monkeypatch: Any, name: str) -> Any:
    nodes: list[Any] = []

    def stop(_goal: dict[str, Any]) -> dict[str, Any]:
        nodes[0].shutdown()  # in the handler: returns at once, the node goes down after it
        return {"sequence": [7]}

    server_node, client = server_and_client(make_node, name, "action", Fibonacci, stop)
    nodes.append(server_node)
    server = server_node.agents["served"].server
    looking = threading.Event()
    answer_waiting_requests = server.answer_waiting_requests

    def look_then_answer(unfinished_result: Any) -> int:
        looking.set()
        answered: int = answer_waiting_requests(unfinished_result)
        return answered

    monkeypatch.setattr(server, "answer_waiting_requests", look_then_answer)
    # Runs before the client asks for the result: it asks once shutdown is looking.
    client.accepted_func = lambda _accepted: looking.wait(EVENT_TIMEOUT)
    result = client.send({"order": 1}, timeout=EVENT_TIMEOUT)
    assert server_node.wait_for_shutdown(EVENT_TIMEOUT)
    return result


def test_a_goal_still_running_when_shutdown_ends_is_aborted_with_a_reason(
    make_node: Any, monkeypatch: Any
) -> None:
    """Shutdown waits JOIN_TIMEOUT for running callbacks; a goal still running then is aborted
    and its client told why, instead of waiting its whole timeout."""
    started, release = threading.Event(), threading.Event()

    running_on: list[threading.Thread] = []

    def goal(_goal: dict[str, Any]) -> dict[str, Any]:
        running_on.append(threading.current_thread())
        started.set()
        release.wait(EVENT_TIMEOUT * 3)
        return {"sequence": [1]}

    server_node, client = server_and_client(
        make_node, "stuck", "action", Fibonacci, goal, conn_name="fib"
    )
    monkeypatch.setattr(node_shutdown, "JOIN_TIMEOUT", 0.1)
    errors: list[str] = []
    monkeypatch.setattr(server_node, "_log_error", errors.append)
    try:
        result = client.send({"order": 3}, block=False)
        assert started.wait(EVENT_TIMEOUT)
        wait_for_the_result_request(server_node, "fib")
        server_node.shutdown()
        outcome = result.result(EVENT_TIMEOUT * 2)
    finally:
        release.set()
    assert outcome["isdone"] is False
    assert outcome["error"].endswith("goal aborted by the server: server is shutting down")
    # The handler left behind ends now: its result goes nowhere, without an error.
    running_on[0].join(EVENT_TIMEOUT)  # an executor thread: it ends after this goal's task
    assert not running_on[0].is_alive()
    assert errors == []


TIMEOUT_WORDS = "timeout must be None or a finite number of seconds >= 0, got"
CLIENT = "agent 'served' (action_client test_msgs/action/Fibonacci)"


@pytest.mark.parametrize(("timeout", "shown"), [("5", "'5'"), (-1, "-1"), (math.inf, "inf")])
def test_a_client_refuses_a_timeout_that_is_not_one(
    make_node: Any, timeout: object, shown: str
) -> None:
    node = make_node()
    with pytest.raises(PyconnectError) as caught:
        node.add_agent(
            conn_name="fib", conn_type="action_client", data_interface=Fibonacci, timeout=timeout
        )
    assert str(caught.value) == (
        f"agent 'fib' (action_client test_msgs/action/Fibonacci): {TIMEOUT_WORDS} {shown}"
    )
    assert "fib" not in node.agents


def test_a_goal_with_a_wrong_timeout_raises_before_it_is_sent(make_node: Any) -> None:
    server_node, client = server_and_client(
        make_node, "wrong_timeout", "action", Fibonacci, lambda goal: {"sequence": [goal["order"]]}
    )
    assert client.send({"order": 1}) == {"sequence": [1], "isdone": True}  # the server is seen
    calls: list[tuple[str, Callable[[], object]]] = [
        (f"send: {TIMEOUT_WORDS} '2'", lambda: client.send({"order": 2}, timeout="2")),
        (
            f"send: {TIMEOUT_WORDS} nan",
            lambda: client.send({"order": 2}, timeout=math.nan, block=False),
        ),
        (
            f"send_async: {TIMEOUT_WORDS} True",
            lambda: asyncio.run(client.send_async({"order": 2}, timeout=True)),
        ),
    ]
    for problem, make_the_call in calls:
        with pytest.raises(PyconnectError) as caught:
            make_the_call()
        assert str(caught.value) == f"{CLIENT}: {problem}"
    assert client.send({"order": 3}) == {"sequence": [3], "isdone": True}
    assert server_node.agents["served"].goal_count == 2  # no goal of the wrong calls was sent


def test_a_handler_returning_none_succeeds_with_the_default_result_and_one_warning(
    make_node: Any, capfd: pytest.CaptureFixture[str]
) -> None:
    _server_node, client = server_and_client(
        make_node, "forgetful", "action", Fibonacci, lambda _goal: None
    )
    assert client.send({"order": 2}) == {"sequence": [], "isdone": True}
    assert client.send({"order": 2}) == {"sequence": [], "isdone": True}
    warning = (
        "agent 'served' (action_server test_msgs/action/Fibonacci): response_func returned "
        "None: answering the default test_msgs/action/Fibonacci_Result"
    )
    assert capfd.readouterr().err.count(warning) == 1


def test_a_result_without_fields_is_not_warned_of(
    make_node: Any, capfd: pytest.CaptureFixture[str]
) -> None:
    # No installed action has a field-less result: the server is asked about one directly.
    server = make_node().add_agent(
        conn_name="fib", conn_type="action_server", data_interface=Fibonacci,
        response_func=lambda _goal: None,
    )  # fmt: skip
    server.warn_of_default_answer(Empty.Response)
    assert "returned None" not in capfd.readouterr().err


def test_a_send_async_that_times_out_reaches_response_func_once(make_node: Any) -> None:
    # Two timers used to race: the loop's (asyncio.wait_for) and the goal's own (PendingCalls'
    # watchdog, which answers the goal as late and so calls response_func). Here the loop's
    # fires first but the watchdog answers before the awaiting task resumes: both answered.
    node = make_node()
    release = threading.Event()
    calls: list[Any] = []
    answered = threading.Event()

    def slow(_goal: dict[str, Any]) -> Iterator[None]:
        while not release.wait(0.01):
            yield None

    def on_result(value: Any) -> None:
        calls.append(value)
        answered.set()

    node.add_agent(
        conn_name="slow", conn_type="action_server", data_interface=Fibonacci, response_func=slow
    )
    client = node.add_agent(
        conn_name="slow", agent_name="slow_client", conn_type="action_client",
        data_interface=Fibonacci, timeout=EVENT_TIMEOUT, response_func=on_result,
    )  # fmt: skip
    node.spin(run_thread=True)
    node.wait_until_connected(timeout=EVENT_TIMEOUT)
    timeout = 1.0

    with manual_clock_loop() as loop:

        async def give_up() -> Any:
            sending = asyncio.ensure_future(client.send_async({"order": 1}, timeout=timeout))
            await asyncio.sleep(0)  # its first step: the goal is sent, any loop timer set
            # Runs right after any timer due at `timeout`, and holds the loop until the goal's
            # own deadline has answered it.
            loop.call_later(timeout + 0.5, lambda: answered.wait(EVENT_TIMEOUT))
            loop.now += timeout + 1.0
            return await sending

        try:
            result = run_on(loop, give_up())
        finally:
            release.set()
    failed = {
        "isdone": False,
        "error": "agent 'slow_client' (action_client test_msgs/action/Fibonacci): "
        "no result within 1.0 s (goal canceled)",
    }
    assert result == failed
    assert calls == [failed]


@pytest.mark.parametrize("loop_kind", ["pyconnect's loop", "the user's loop"])
def test_a_blocking_send_on_the_nodes_loop_thread_raises(make_node: Any, loop_kind: str) -> None:
    # The loop's thread would wait for a result that the server's async handler (on the same
    # loop) must produce: a deadlock, or a timeout, with no word of why.
    async def fib(goal: dict[str, Any]) -> dict[str, Any]:
        await asyncio.sleep(0)
        return {"sequence": [goal["order"]]}

    with contextlib.ExitStack() as stack:
        user_loop = (
            stack.enter_context(loop_in_a_thread(asyncio.new_event_loop()))
            if loop_kind == "the user's loop"
            else None
        )
        node = make_node(loop=user_loop)
        node.add_agent(
            conn_name="fib", conn_type="action_server", data_interface=Fibonacci,
            response_func=fib,
        )  # fmt: skip
        client = node.add_agent(
            conn_name="fib", agent_name="fib_client", conn_type="action_client",
            data_interface=Fibonacci, timeout=EVENT_TIMEOUT,
        )  # fmt: skip
        node.spin(run_thread=True)
        node.wait_until_connected(timeout=EVENT_TIMEOUT)

        async def on_the_loop() -> tuple[str, Any]:
            try:
                client.send({"order": 2})
            except PyconnectError as error:
                refused = str(error)
            else:
                refused = "(not refused)"
            return refused, await client.send_async({"order": 3})

        refused, awaited = run_on(user_loop or node.coroutines.loop, on_the_loop())
        node.shutdown()
    assert refused == (
        "agent 'fib_client' (action_client test_msgs/action/Fibonacci): send() blocks, and was "
        "called on the thread of the node's asyncio loop, which the answer may need: use "
        "`await agent.send_async(...)` there instead"
    )
    assert awaited == {"sequence": [3], "isdone": True}


def test_an_action_server_that_fails_half_way_leaves_no_reason_publisher(
    make_node: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    node = make_node()

    def refuse(*_args: Any, **_kwargs: Any) -> Any:
        raise ValueError("Failed to create action server")

    # rcl refuses e.g. a negative result_timeout only here, after the reason publisher exists.
    monkeypatch.setattr(action_server_agent, "RetainingActionServer", refuse)
    with pytest.raises(ValueError, match="Failed to create action server"):
        node.add_agent(
            conn_name="fib", conn_type="action_server", data_interface=Fibonacci,
            response_func=fibonacci,
        )  # fmt: skip
    assert "fib" not in node.agents
    assert node.ros_node.count_publishers("/fib/_action/abort_reason") == 0


def test_an_action_client_that_fails_half_way_leaves_no_action_client(
    make_node: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    node = make_node()

    def refuse(*_args: Any, **_kwargs: Any) -> Any:
        raise RuntimeError("no subscription today")

    monkeypatch.setattr(action_client_agent, "AbortReasons", refuse)
    with pytest.raises(RuntimeError, match="no subscription today"):
        node.add_agent(conn_name="fib", conn_type="action_client", data_interface=Fibonacci)
    assert "fib" not in node.agents
    assert node.ros_node.count_subscribers("/fib/_action/status") == 0
    assert node.ros_node.count_subscribers("/fib/_action/feedback") == 0


def test_a_goal_with_a_wrong_feedback_func_or_block_raises_before_it_is_sent(
    make_node: Any,
) -> None:
    server_node, client = server_and_client(
        make_node, "wrong_call", "action", Fibonacci, lambda goal: {"sequence": [goal["order"]]}
    )
    hint = "; pass the function itself, not its name"
    calls: list[tuple[str, Callable[[], object]]] = [
        (
            f"send: feedback_func: expected a callable or None, got str 'print'{hint}",
            lambda: client.send({"order": 2}, feedback_func="print"),
        ),
        (
            "send: feedback_func: expected a callable or None, got int 3",
            lambda: client.send({"order": 2}, feedback_func=3, block=False),
        ),
        ("send: block: expected bool, got str 'no'", lambda: client.send({"order": 2}, block="no")),
        ("send: block: expected bool, got NoneType None", lambda: client.send(block=None)),
        (
            f"send_async: feedback_func: expected a callable or None, got str 'print'{hint}",
            lambda: asyncio.run(client.send_async({"order": 2}, feedback_func="print")),
        ),
    ]
    for problem, make_the_call in calls:
        with pytest.raises(PyconnectError) as caught:
            make_the_call()
        assert str(caught.value) == f"{CLIENT}: {problem}"
    assert client.send({"order": 3}) == {"sequence": [3], "isdone": True}
    assert server_node.agents["served"].goal_count == 1  # no goal of the wrong calls was sent
