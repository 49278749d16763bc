"""Client agents' non-blocking calls: answered without spin(), on shutdown, and when undecodable."""

from __future__ import annotations

import asyncio
import concurrent.futures
import gc
import threading
import time
import weakref
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from std_srvs.srv import SetBool
from test_msgs.action import Fibonacci

from pyconnect.errors import PyconnectError
from pyconnect.ros import pending_calls

from .conftest import EVENT_TIMEOUT, repeat_until

SERVICE = "agent 'toggle_client' (service_client std_srvs/srv/SetBool)"
ACTION = "agent 'fib_client' (action_client test_msgs/action/Fibonacci)"


def _service_pair(node: Any, **client_options: Any) -> Any:
    node.add_agent(
        conn_name="toggle", conn_type="service_server", data_interface=SetBool,
        response_func=lambda request: {"success": request["data"], "message": "ok"},
    )  # fmt: skip
    return node.add_agent(
        conn_name="toggle", agent_name="toggle_client", conn_type="service_client",
        data_interface=SetBool, timeout=EVENT_TIMEOUT, **client_options,
    )  # fmt: skip


def _action_pair(node: Any, handler: Any = None, **client_options: Any) -> Any:
    node.add_agent(
        conn_name="fib", conn_type="action_server", data_interface=Fibonacci,
        response_func=handler or (lambda goal: {"sequence": [goal["order"]]}),
    )  # fmt: skip
    return node.add_agent(
        conn_name="fib", agent_name="fib_client", conn_type="action_client",
        data_interface=Fibonacci, timeout=EVENT_TIMEOUT, **client_options,
    )  # fmt: skip


def _until_cancelled(
    cancelled: threading.Event, started: threading.Event | None = None
) -> Callable[[dict[str, Any]], Iterator[None]]:
    """An action handler that yields until its goal is canceled (then sets ``cancelled``)."""

    def runs_until_cancelled(_goal: dict[str, Any]) -> Iterator[None]:
        if started is not None:
            started.set()
        try:
            for _ in range(int(EVENT_TIMEOUT / 0.01)):  # bounded: a regression fails, not hangs
                cancelled.wait(0.01)
                yield None
        except GeneratorExit:  # the server closes a canceled goal's generator
            cancelled.set()
            raise
        return None

    return runs_until_cancelled


def test_non_blocking_calls_are_answered_on_a_node_nobody_spins(make_node: Any) -> None:
    # As a blocking send() does, the call starts the node spinning in the background.
    node = make_node()
    service = _service_pair(node)
    action = _action_pair(node)
    assert service.send({"data": True}, block=False).result(EVENT_TIMEOUT) == {
        "success": True, "message": "ok", "isdone": True,
    }  # fmt: skip
    assert asyncio.run(action.send_async({"order": 3})) == {"sequence": [3], "isdone": True}


def test_calls_on_a_shut_down_node_fail_with_its_name(make_node: Any) -> None:
    node = make_node()
    service = _service_pair(node)
    action = _action_pair(node)
    node.shutdown()
    for client, name in ((service, SERVICE), (action, ACTION)):
        failed = {"isdone": False, "error": f"{name}: node '/test_node' is shut down"}
        assert client.send({}, block=False).result(EVENT_TIMEOUT) == failed
        assert asyncio.run(client.send_async({})) == failed
    with pytest.raises(PyconnectError, match="node '/test_node' is shut down"):
        node.wait_until_connected(timeout=1.0)


def test_an_open_non_blocking_goal_fails_when_the_node_shuts_down(make_node: Any) -> None:
    node = make_node()
    started = threading.Event()

    def never_ends(_goal: dict[str, Any]) -> Iterator[None]:
        started.set()
        while not node.shutdown_event.is_set():
            yield None
        return None

    action = _action_pair(node, never_ends)
    future = action.send({"order": 1}, block=False)
    assert started.wait(EVENT_TIMEOUT)
    node.shutdown()
    assert future.result(EVENT_TIMEOUT) == {
        "isdone": False, "error": f"{ACTION}: node '/test_node' shut down during the goal",
    }  # fmt: skip


@pytest.mark.parametrize("how", ["timeout", "task cancelled"])
def test_giving_up_on_send_async_cancels_the_goal(make_node: Any, how: str) -> None:
    node = make_node()
    started = threading.Event()
    cancelled = threading.Event()

    action = _action_pair(node, _until_cancelled(cancelled, started))
    node.spin(run_thread=True)

    async def give_up() -> Any:
        if how == "timeout":
            return await action.send_async({"order": 1}, timeout=0.5)
        task = asyncio.ensure_future(action.send_async({"order": 1}))
        await asyncio.get_running_loop().run_in_executor(None, started.wait, EVENT_TIMEOUT)
        task.cancel()
        with pytest.raises(asyncio.CancelledError):
            await task
        return None

    result = asyncio.run(give_up())
    if how == "timeout":
        assert result == {
            "isdone": False, "error": f"{ACTION}: no result within 0.5 s (goal canceled)",
        }  # fmt: skip
    assert cancelled.wait(EVENT_TIMEOUT), "the server never saw the goal canceled"


def test_an_undecodable_answer_is_a_failed_call_that_response_func_sees(make_node: Any) -> None:
    def cannot_read(_msg: Any) -> Any:
        raise ValueError("cannot read this reply")

    node = make_node()
    answers: list[Any] = []
    answered = threading.Event()

    def on_answer(value: Any) -> None:
        answers.append(value)
        answered.set()

    service = _service_pair(node, decode_func=cannot_read)
    action = _action_pair(node, decode_func=cannot_read, response_func=on_answer)
    node.spin(run_thread=True)
    assert service.send({"data": True}) == {
        "isdone": False, "error": f"{SERVICE}: could not decode the response: "
        "decode_func raised ValueError: cannot read this reply",
    }  # fmt: skip
    failed = {
        "isdone": False, "error": f"{ACTION}: could not decode the result: "
        "decode_func raised ValueError: cannot read this reply",
    }  # fmt: skip
    assert action.send({"order": 1}) == failed
    assert answered.wait(EVENT_TIMEOUT)
    assert answers == [failed]
    assert service.error_count == 1 and action.error_count == 1


def test_a_non_blocking_call_answered_too_late_fails_after_its_timeout(make_node: Any) -> None:
    node = make_node()
    release = threading.Event()
    cancelled = threading.Event()

    def never_in_time(_request: dict[str, Any]) -> dict[str, Any]:
        release.wait(EVENT_TIMEOUT)
        return {"success": True}

    node.add_agent(
        conn_name="slow", conn_type="service_server", data_interface=SetBool,
        response_func=never_in_time,
    )  # fmt: skip
    service = node.add_agent(
        conn_name="slow", agent_name="toggle_client", conn_type="service_client",
        data_interface=SetBool,
    )  # fmt: skip
    action = _action_pair(node, _until_cancelled(cancelled))
    node.spin(run_thread=True)
    try:
        call = service.send({"data": True}, block=False, timeout=0.5)
        goal = action.send({"order": 1}, block=False, timeout=0.5)
        assert call.result(EVENT_TIMEOUT) == {
            "isdone": False, "error": f"{SERVICE}: no response from /slow within 0.5 s",
        }  # fmt: skip
        assert goal.result(EVENT_TIMEOUT) == {
            "isdone": False, "error": f"{ACTION}: no result within 0.5 s (goal canceled)",
        }  # fmt: skip
        assert cancelled.wait(EVENT_TIMEOUT), "the server never saw the late goal canceled"
    finally:
        release.set()


def _threads_named(name: str) -> list[threading.Thread]:
    return [thread for thread in threading.enumerate() if thread.name == name]


def _all_end(threads: list[threading.Thread]) -> bool:
    """Whether ``threads`` all end within the test timeout (joined, not slept on)."""
    deadline = time.monotonic() + EVENT_TIMEOUT
    for thread in threads:
        thread.join(max(0.0, deadline - time.monotonic()))
    return not any(thread.is_alive() for thread in threads)


@pytest.mark.parametrize("kind", ["service", "action"])
def test_answered_calls_are_released_long_before_their_timeout(make_node: Any, kind: str) -> None:
    # The watchdog of late answers held every call with a timeout (and its decoded answer)
    # until that timeout ran out, answered or not.
    node = make_node()
    if kind == "service":
        client, data, name = _service_pair(node), {"data": True}, "toggle_client"
    else:
        client, data, name = _action_pair(node), {"order": 1}, "fib_client"
    node.spin(run_thread=True)
    node.wait_until_connected(timeout=EVENT_TIMEOUT)
    answered: list[weakref.ref[Any]] = []
    for _ in range(30):
        future = client.send(data, block=False, timeout=3600.0)
        assert future.result(EVENT_TIMEOUT)["isdone"] is True
        answered.append(weakref.ref(future))
        del future
    assert _all_end(_threads_named(f"pyconnect-{name}-deadlines")), "the watchdog outlived them"
    gc.collect()
    assert sum(ref() is not None for ref in answered) == 0


def _absent_server_client(node: Any) -> Any:
    return node.add_agent(
        conn_name="not_yet", agent_name="early_client", conn_type="service_client",
        data_interface=SetBool,
    )  # fmt: skip


def test_cancelled_calls_to_an_absent_server_leave_no_thread_waiting(make_node: Any) -> None:
    # Each call waited for the server on a thread of its own, polling the graph until the
    # server came (with no timeout, for ever), whether its caller had given up or not.
    node = make_node()
    client = _absent_server_client(node)
    node.spin(run_thread=True)
    futures = [client.send({"data": True}, block=False) for _ in range(20)]
    waiters = _threads_named("pyconnect-early_client-wait")
    assert 1 <= len(waiters) <= 1, "one thread waits for the server for all the calls"
    for future in futures:
        assert future.cancel()
    assert _all_end(waiters), "a thread still waits for the server of cancelled calls"


def test_a_call_cancelled_before_the_server_appears_never_reaches_it(make_node: Any) -> None:
    node = make_node()
    client = _absent_server_client(node)
    node.spin(run_thread=True)
    dropped = client.send({"data": False}, block=False)
    kept = [client.send({"data": True}, block=False) for _ in range(3)]
    assert dropped.cancel()
    requests: list[bool] = []
    node.add_agent(
        conn_name="not_yet", conn_type="service_server", data_interface=SetBool,
        response_func=lambda request: requests.append(request["data"]) or {"success": True},
    )  # fmt: skip
    for future in kept:
        assert future.result(EVENT_TIMEOUT)["success"] is True
    assert requests == [True, True, True]


def test_calls_waiting_for_the_server_fail_each_after_its_own_timeout(make_node: Any) -> None:
    node = make_node()
    client = _absent_server_client(node)
    node.spin(run_thread=True)
    soon = client.send({"data": True}, block=False, timeout=0.2)
    later = client.send({"data": True}, block=False, timeout=3600.0)
    assert soon.result(EVENT_TIMEOUT) == {
        "isdone": False,
        "error": "agent 'early_client' (service_client std_srvs/srv/SetBool): "
        "no server for /not_yet within 0.2 s",
    }
    assert not later.done()
    assert later.cancel()


def test_a_call_made_as_the_server_appears_goes_after_the_waiting_ones(
    make_node: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A call made once the server was seen went out at once, while the calls made before it
    still waited for the waiter's next look (up to a poll later): requests out of order."""
    monkeypatch.setattr(pending_calls, "POLL", 0.5)  # a wide window between two looks
    node = make_node()
    client = _absent_server_client(node)
    node.spin(run_thread=True)
    waiting = [client.send({"data": True}, block=False) for _ in range(3)]
    order: list[bool] = []
    node.add_agent(
        conn_name="not_yet", conn_type="service_server", data_interface=SetBool,
        response_func=lambda request: order.append(request["data"]) or {"success": True},
    )  # fmt: skip
    seen = threading.Event()
    assert repeat_until(seen, lambda: client.is_connected() and seen.set())
    last = client.send({"data": False}, block=False)
    for future in [*waiting, last]:
        assert future.result(EVENT_TIMEOUT)["success"] is True
    assert order == [True, True, True, False]


def test_cancel_fails_goals_still_waiting_for_their_server(make_node: Any) -> None:
    """cancel() looked at goals already sent only: a goal waiting for its server was sent,
    and ran, once the server appeared."""
    node = make_node()
    client = node.add_agent(
        conn_name="late_fib", conn_type="action_client", data_interface=Fibonacci,
        timeout=EVENT_TIMEOUT,
    )  # fmt: skip
    node.spin(run_thread=True)
    waiting = client.send({"order": 3}, block=False)
    assert client.cancel() == 1
    assert waiting.result(EVENT_TIMEOUT)["error"] == (
        "agent 'late_fib' (action_client test_msgs/action/Fibonacci): "
        "goal canceled before it was sent"
    )
    executed: list[int] = []
    node.add_agent(
        conn_name="late_fib", agent_name="server", conn_type="action_server",
        data_interface=Fibonacci,
        response_func=lambda goal: executed.append(goal["order"]) or {"sequence": [1]},
    )  # fmt: skip
    assert client.send({"order": 1})["sequence"] == [1]
    assert executed == [1]


class _Host:
    """What ``PendingCalls`` asks of its node: a node that spins and never shuts down."""

    name = qualified_name = "/host"

    def __init__(self) -> None:
        self.shutdown_event = threading.Event()

    def ensure_spinning(self) -> None:
        pass


def _never_answered_calls() -> pending_calls.PendingCalls:
    """A ``PendingCalls`` whose server is ready but never answers: only timeouts settle."""
    return pending_calls.PendingCalls(
        _Host(),  # type: ignore[arg-type]
        agent_name="huge",
        during="call",
        server_ready=lambda: True,
        failed=lambda text: {"isdone": False, "error": text},
    )


def _start(calls: pending_calls.PendingCalls, timeout: float) -> Any:
    result: concurrent.futures.Future[Any] = concurrent.futures.Future()
    calls.start(
        result, lambda _result: None, timeout=timeout, missing="no server", late=f"late {timeout}"
    )
    return result


def test_a_call_with_a_huge_timeout_leaves_the_next_calls_timeouts_working() -> None:
    """timeout=1e10 made the watchdog sleep past threading.TIMEOUT_MAX: an OverflowError
    ended it, and the 0.2 s call after it was never answered."""
    calls = _never_answered_calls()
    huge = _start(calls, 1e10)
    time.sleep(0.1)
    assert _threads_named("pyconnect-huge-deadlines"), "the watchdog sleeps on the huge deadline"
    short = _start(calls, 0.2)
    assert short.result(EVENT_TIMEOUT) == {"isdone": False, "error": "late 0.2"}
    assert not huge.done()
    assert huge.cancel()


@pytest.mark.filterwarnings("ignore::pytest.PytestUnhandledThreadExceptionWarning")
def test_a_watchdog_that_died_is_started_again(monkeypatch: pytest.MonkeyPatch) -> None:
    """A watchdog ended by an error stayed registered: no call's timeout was heeded again."""
    monkeypatch.setattr(pending_calls, "LONGEST_SLEEP", 1e12)  # the sleep raises again
    calls = _never_answered_calls()
    _start(calls, 1e10)
    watchdogs = _threads_named("pyconnect-huge-deadlines")
    assert _all_end(watchdogs), "the watchdog should have died of its OverflowError"
    monkeypatch.setattr(pending_calls, "LONGEST_SLEEP", 3600.0)
    short = _start(calls, 0.2)
    assert short.result(EVENT_TIMEOUT) == {"isdone": False, "error": "late 0.2"}
