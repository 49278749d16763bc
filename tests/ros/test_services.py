"""service_server and service_client agents."""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import math
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

import pytest
from std_srvs.srv import Empty, SetBool, Trigger
from test_msgs.srv import BasicTypes

from pyconnect.errors import PyconnectError

from .conftest import EVENT_TIMEOUT, server_and_client
from .manual_clock import loop_in_a_thread, manual_clock_loop, run_on


def _set_bool_pair(node: Any, handler: Any) -> Any:
    node.add_agent(
        conn_name="enable",
        conn_type="service_server",
        data_interface=SetBool,
        response_func=handler,
    )
    client = node.add_agent(
        conn_name="enable",
        agent_name="enable_client",
        conn_type="service_client",
        data_interface=SetBool,
        timeout=EVENT_TIMEOUT,
    )
    node.spin(run_thread=True)
    return client


def test_blocking_call_returns_reformed_response(make_node: Any) -> None:
    node = make_node()
    client = _set_bool_pair(
        node, lambda request: {"success": request["data"], "message": "as asked"}
    )
    assert client.send({"data": True}) == {"success": True, "message": "as asked", "isdone": True}
    assert client.get({"data": False}) == {
        "success": False,
        "message": "as asked",
        "isdone": True,
    }


def test_non_blocking_call_returns_a_future(make_node: Any) -> None:
    node = make_node()
    client = _set_bool_pair(node, lambda request: {"success": True, "message": "later"})
    future = client.send({"data": True}, block=False)
    assert isinstance(future, concurrent.futures.Future)
    assert future.result(EVENT_TIMEOUT) == {"success": True, "message": "later", "isdone": True}


def test_raising_handler_still_answers_with_the_error(make_node: Any) -> None:
    node = make_node()

    def handler(_request: dict[str, Any]) -> dict[str, Any]:
        raise RuntimeError("motor driver offline")

    client = _set_bool_pair(node, handler)
    assert client.send({"data": True}) == {
        "success": False,
        "message": "RuntimeError: motor driver offline",
        "isdone": True,
    }
    server = node.agents["enable"]
    assert server.last_error == (
        "agent 'enable' (service_server std_srvs/srv/SetBool): response_func raised "
        "RuntimeError: motor driver offline"
    )
    # The server keeps answering.
    assert client.send({"data": False})["message"] == "RuntimeError: motor driver offline"


def test_raising_handler_without_message_field_answers_default(make_node: Any) -> None:
    node = make_node()

    def handler(_request: dict[str, Any]) -> dict[str, Any]:
        raise ValueError("no")

    node.add_agent(
        conn_name="basic",
        conn_type="service_server",
        data_interface=BasicTypes,
        response_func=handler,
    )
    client = node.add_agent(
        conn_name="basic", agent_name="c", conn_type="service_client", data_interface=BasicTypes
    )
    node.spin(run_thread=True)
    response = client.send({"int32_value": 3}, timeout=EVENT_TIMEOUT)
    assert response["isdone"] is True
    assert response["int32_value"] == 0
    assert response["string_value"] == ""


def test_no_server_times_out_with_isdone_false(make_node: Any) -> None:
    node = make_node()
    client = node.add_agent(conn_name="nobody", conn_type="service_client", data_interface=Trigger)
    node.spin(run_thread=True)
    assert client.send({}, timeout=0.2) == {
        "isdone": False,
        "error": "agent 'nobody' (service_client std_srvs/srv/Trigger): no server for /nobody "
        "within 0.2 s",
    }


def test_blocking_send_without_spin_thread(make_node: Any) -> None:
    node = make_node()
    node.add_agent(
        conn_name="ping",
        conn_type="service_server",
        data_interface=Trigger,
        response_func=lambda _request: {"success": True, "message": "pong"},
    )
    client = node.add_agent(
        conn_name="ping", agent_name="c", conn_type="service_client", data_interface=Trigger
    )
    # Nobody spins: the caller's thread spins until the response is there.
    assert client.send({}, timeout=EVENT_TIMEOUT) == {
        "success": True,
        "message": "pong",
        "isdone": True,
    }


def test_server_needs_response_func(make_node: Any) -> None:
    node = make_node()
    with pytest.raises(PyconnectError) as caught:
        node.add_agent(conn_name="x", conn_type="service_server", data_interface=Trigger)
    assert str(caught.value) == (
        "agent 'x' (service_server std_srvs/srv/Trigger): a 'service_server' agent needs a "
        "response_func"
    )


def test_a_call_cut_short_by_shutdown_says_so(make_node: Any) -> None:
    """Not "no response within 60 s": the wait ended because the caller's node shut down."""
    server_node, caller = make_node("slow_server"), make_node("caller")
    entered, release = threading.Event(), threading.Event()

    def slow(_request: dict[str, Any]) -> dict[str, Any]:
        entered.set()
        release.wait(EVENT_TIMEOUT)
        return {"success": True, "message": ""}

    server_node.add_agent(
        conn_name="slow", conn_type="service_server", data_interface=Trigger, response_func=slow
    )
    client = caller.add_agent(
        conn_name="slow", conn_type="service_client", data_interface=Trigger, timeout=600
    )
    server_node.spin(run_thread=True)
    caller.spin(run_thread=True)
    outcome: list[Any] = []
    calling = threading.Thread(target=lambda: outcome.append(client.send()))
    calling.start()
    try:
        assert entered.wait(EVENT_TIMEOUT)
        caller.shutdown()
        calling.join(EVENT_TIMEOUT)
    finally:
        release.set()
    assert outcome == [
        {
            "isdone": False,
            "error": "agent 'slow' (service_client std_srvs/srv/Trigger): node '/caller' shut "
            "down during the call",
        }
    ]


def test_a_burst_of_more_than_ten_requests_loses_none(make_node: Any) -> None:
    """README (QoS): services keep every request (keep-all, both sides); rclpy's keep-last 10
    silently loses some of a burst. The handler holds the first request until all 40 are sent,
    so the rest pile up in the server's reader and the client's writer."""
    server_node, caller = make_node("burst_server"), make_node("burst_client")
    all_sent = threading.Event()
    handled: list[int] = []

    def handler(request: dict[str, Any]) -> dict[str, Any]:
        assert all_sent.wait(EVENT_TIMEOUT)
        handled.append(1)
        return {"success": request["data"], "message": str(len(handled))}

    server_node.add_agent(
        conn_name="burst", conn_type="service_server", data_interface=SetBool,
        response_func=handler,
    )  # fmt: skip
    client = caller.add_agent(
        conn_name="burst", conn_type="service_client", data_interface=SetBool,
        timeout=EVENT_TIMEOUT,
    )  # fmt: skip
    server_node.spin(run_thread=True)
    caller.spin(run_thread=True)
    caller.wait_until_connected(timeout=EVENT_TIMEOUT)
    try:
        futures = [client.send({"data": True}, block=False) for _ in range(40)]
    finally:
        all_sent.set()
    # A lost request is never answered (a non-blocking call's timeout covers finding the server).
    _done, lost = concurrent.futures.wait(futures, timeout=2 * EVENT_TIMEOUT)
    assert not lost, f"{len(lost)} of 40 requests were never answered"
    results = [future.result() for future in futures]
    assert [result["isdone"] for result in results] == [True] * 40, results
    assert sorted(int(result["message"]) for result in results) == list(range(1, 41))
    assert len(handled) == 40


def test_a_handler_that_shuts_its_node_down_still_replies(make_node: Any) -> None:
    """A "stop" service: shutdown() in the handler returns at once (the node cannot go down
    under its own callback), the reply is sent, then the node shuts down."""
    down_in_handler: list[bool] = []

    def stop(_request: dict[str, Any]) -> dict[str, Any]:
        server_node.shutdown()
        down_in_handler.append(server_node.wait_for_shutdown(0))
        return {"success": True, "message": "stopping"}

    server_node, client = server_and_client(make_node, "stopping", "service", Trigger, stop)
    assert client.send() == {"success": True, "message": "stopping", "isdone": True}
    assert down_in_handler == [False]
    assert server_node.wait_for_shutdown(EVENT_TIMEOUT)
    assert not server_node.context.ok()  # all the way down: the node left its context


@pytest.mark.parametrize("kind", ["plain", "async"])
def test_a_handler_that_calls_sys_exit_answers_then_shuts_its_node_down(
    make_node: Any, kind: str
) -> None:
    """``SystemExit`` went past the handler's error answer: rclpy sent no response, and the
    client waited for its whole timeout while the node shut down."""

    def stop(_request: dict[str, Any]) -> dict[str, Any]:
        sys.exit("mission complete")

    async def stop_async(request: dict[str, Any]) -> dict[str, Any]:
        return stop(request)

    handler = stop if kind == "plain" else stop_async
    server_node, client = server_and_client(make_node, f"exit_{kind}", "service", Trigger, handler)
    started = time.monotonic()
    assert client.send(timeout=EVENT_TIMEOUT) == {
        "success": False, "message": "SystemExit: mission complete", "isdone": True,
    }  # fmt: skip
    assert time.monotonic() - started < EVENT_TIMEOUT / 2, "answered only near its timeout"
    assert server_node.wait_for_shutdown(EVENT_TIMEOUT)
    assert not server_node.context.ok()  # all the way down: the node left its context
    assert server_node.agents["served"].error_count == 1


def test_requests_still_waiting_at_shutdown_are_refused(make_node: Any, monkeypatch: Any) -> None:
    """The request being handled gets its reply; the ones queued behind it (never taken: the
    executor has stopped) are answered "server is shutting down" instead of timing out."""
    entered, release = threading.Event(), threading.Event()

    def slow(request: dict[str, Any]) -> dict[str, Any]:
        entered.set()
        release.wait(EVENT_TIMEOUT)
        return {"success": True, "message": "handled"}

    server_node, client = server_and_client(make_node, "refusing", "service", SetBool, slow)
    stop = server_node._executor.stop

    def stop_then_release() -> None:
        stop()
        release.set()  # the handler ends after the executor stopped

    monkeypatch.setattr(server_node._executor, "stop", stop_then_release)
    try:
        replies = [client.send({"data": True}, block=False) for _ in range(3)]
        assert entered.wait(EVENT_TIMEOUT)
        server_node.shutdown()
    finally:
        release.set()
    answers = [reply.result(EVENT_TIMEOUT * 2) for reply in replies]
    assert answers[0] == {"success": True, "message": "handled", "isdone": True}
    refused = {"success": False, "message": "server is shutting down", "isdone": True}
    assert answers[1:] == [refused, refused]


TIMEOUT_WORDS = "timeout must be None or a finite number of seconds >= 0, got"


@pytest.mark.parametrize(
    ("timeout", "shown"), [("5", "'5'"), (-1, "-1"), (math.nan, "nan"), (True, "True")]
)
def test_a_client_refuses_a_timeout_that_is_not_one(
    make_node: Any, timeout: object, shown: str
) -> None:
    node = make_node()
    with pytest.raises(PyconnectError) as caught:
        node.add_agent(
            conn_name="enable", conn_type="service_client", data_interface=SetBool, timeout=timeout
        )
    assert str(caught.value) == (
        f"agent 'enable' (service_client std_srvs/srv/SetBool): {TIMEOUT_WORDS} {shown}"
    )
    assert "enable" not in node.agents


def test_a_call_with_a_wrong_timeout_raises_before_its_request_is_sent(make_node: Any) -> None:
    requests: list[Any] = []

    def handler(request: dict[str, Any]) -> dict[str, Any]:
        requests.append(request)
        return {"success": True, "message": "ok"}

    _server_node, client = server_and_client(
        make_node, "wrong_timeout", "service", SetBool, handler
    )
    answer = {"success": True, "message": "ok", "isdone": True}
    assert client.send({"data": True}) == answer  # the server is seen: the next call sends at once
    agent = "agent 'served' (service_client std_srvs/srv/SetBool)"
    calls: list[tuple[str, Callable[[], object]]] = [
        (f"send: {TIMEOUT_WORDS} '2'", lambda: client.send({"data": False}, timeout="2")),
        (
            f"send: {TIMEOUT_WORDS} -1.0",
            lambda: client.send({"data": False}, timeout=-1.0, block=False),
        ),
        (
            f"send_async: {TIMEOUT_WORDS} '2'",
            lambda: asyncio.run(client.send_async({"data": False}, timeout="2")),
        ),
        (
            "send: block: expected bool, got str 'no'",
            lambda: client.send({"data": False}, block="no"),
        ),
    ]
    for problem, make_the_call in calls:
        with pytest.raises(PyconnectError) as caught:
            make_the_call()
        assert str(caught.value) == f"{agent}: {problem}"
    client.timeout = "5"  # changed after the agent was made: each call checks it again
    with pytest.raises(PyconnectError) as caught:
        client.send({"data": False})
    assert str(caught.value) == f"{agent}: send: {TIMEOUT_WORDS} '5'"
    client.timeout = EVENT_TIMEOUT
    assert client.send({"data": True}) == answer
    assert requests == [{"data": True}, {"data": True}]  # the server saw none of the others


def test_a_handler_returning_none_answers_the_default_response_with_one_warning(
    make_node: Any, capfd: pytest.CaptureFixture[str]
) -> None:
    _server_node, client = server_and_client(
        make_node, "forgetful", "service", SetBool, lambda _request: None
    )
    default = {"success": False, "message": "", "isdone": True}
    assert client.send({"data": True}) == default
    assert client.send({"data": True}) == default
    warning = (
        "agent 'served' (service_server std_srvs/srv/SetBool): response_func returned None: "
        "answering the default std_srvs/srv/SetBool_Response"
    )
    assert capfd.readouterr().err.count(warning) == 1


def test_a_handler_returning_none_for_a_response_without_fields_is_not_warned_of(
    make_node: Any, capfd: pytest.CaptureFixture[str]
) -> None:
    _server_node, client = server_and_client(
        make_node, "empty", "service", Empty, lambda _request: None
    )
    assert client.send({}) == {"isdone": True}
    assert "returned None" not in capfd.readouterr().err


def test_send_async_times_out_by_the_calls_own_deadline_only(make_node: Any) -> None:
    # One timer: the call's own (PendingCalls). A second one on the awaiting loop raced it:
    # here the loop's clock alone passes the timeout, while the answer comes in time.
    release = threading.Event()

    def late_but_in_time(_request: dict[str, Any]) -> dict[str, Any]:
        release.wait(EVENT_TIMEOUT)
        return {"success": True, "message": "in time"}

    _server_node, client = server_and_client(make_node, "one_timer", "service", Trigger,
                                             late_but_in_time)  # fmt: skip
    with manual_clock_loop() as loop:

        async def call() -> Any:
            calling = asyncio.ensure_future(client.send_async(timeout=EVENT_TIMEOUT))
            await asyncio.sleep(0)  # its first step: the request is sent, any loop timer set
            loop.now += 2 * EVENT_TIMEOUT
            for _ in range(5):  # turns of the loop: a timer due now has fired by then
                await asyncio.sleep(0)
            release.set()
            return await calling

        try:
            assert run_on(loop, call()) == {"success": True, "message": "in time", "isdone": True}
        finally:
            release.set()


@pytest.mark.parametrize("loop_kind", ["pyconnect's loop", "the user's loop"])
def test_a_blocking_send_on_the_nodes_loop_thread_raises(make_node: Any, loop_kind: str) -> None:
    # The loop's thread would wait for an answer that the server's async handler (on the same
    # loop) must give: a deadlock, or a timeout, with no word of why.
    async def add(request: dict[str, Any]) -> dict[str, Any]:
        await asyncio.sleep(0)
        return {"int64_value": request["int64_value"] + 1}

    with contextlib.ExitStack() as stack:
        user_loop = (
            stack.enter_context(loop_in_a_thread(asyncio.new_event_loop()))
            if loop_kind == "the user's loop"
            else None
        )
        node = make_node(loop=user_loop)
        node.add_agent(
            conn_name="add", conn_type="service_server", data_interface=BasicTypes,
            response_func=add,
        )  # fmt: skip
        client = node.add_agent(
            conn_name="add", agent_name="adder", conn_type="service_client",
            data_interface=BasicTypes, timeout=EVENT_TIMEOUT,
        )  # fmt: skip
        node.spin(run_thread=True)
        node.wait_until_connected(timeout=EVENT_TIMEOUT)

        async def on_the_loop() -> tuple[list[str], Any]:
            refused = []
            for blocking in (lambda: client.send({"int64_value": 1}), client.get):
                try:
                    blocking()
                except PyconnectError as error:
                    refused.append(str(error))
            return refused, await client.send_async({"int64_value": 2})

        refused, awaited = run_on(user_loop or node.coroutines.loop, on_the_loop())
        node.shutdown()
    assert (
        refused
        == [
            "agent 'adder' (service_client test_msgs/srv/BasicTypes): send() blocks, and was called "
            "on the thread of the node's asyncio loop, which the answer may need: use "
            "`await agent.send_async(...)` there instead"
        ]
        * 2
    )
    assert awaited["int64_value"] == 3
