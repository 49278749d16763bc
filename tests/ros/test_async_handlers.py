"""``async def`` handlers for every agent kind that takes one, and ``send_async`` on a user loop."""

from __future__ import annotations

import asyncio
import sys
import threading
from collections.abc import AsyncIterator, Iterator
from typing import Any

import pytest
from std_msgs.msg import String
from std_srvs.srv import SetBool, Trigger
from test_msgs.action import Fibonacci

from pyconnect.errors import PyconnectError
from pyconnect.ros import coroutines

from .conftest import EVENT_TIMEOUT, repeat_until, server_and_client, wait_for_the_result_request


@pytest.fixture
def user_loop() -> Iterator[asyncio.AbstractEventLoop]:
    """An asyncio loop running in a thread of its own, as an app's loop would."""
    loop = asyncio.new_event_loop()
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    yield loop
    loop.call_soon_threadsafe(loop.stop)
    thread.join(EVENT_TIMEOUT)
    loop.close()


def _run(loop: asyncio.AbstractEventLoop, coroutine: Any) -> Any:
    return asyncio.run_coroutine_threadsafe(coroutine, loop).result(EVENT_TIMEOUT)


def test_async_sub_handler_runs_in_order_and_its_errors_are_reported(make_node: Any) -> None:
    node = make_node()
    seen: list[str] = []
    three = threading.Event()

    async def on_text(text: str) -> None:
        await asyncio.sleep(0.001)
        if text == "bad":
            raise ValueError("cannot use 'bad'")
        if text == "cancelled":  # something the handler awaited was cancelled: reported too
            gone = asyncio.get_running_loop().create_future()
            gone.cancel()
            await gone
        seen.append(text)
        if len(seen) == 3:
            three.set()

    sub = node.add_agent(
        conn_name="words", conn_type="sub", data_interface=String, response_func=on_text,
        qos=100,
    )  # fmt: skip
    pub = node.add_agent(
        conn_name="words", agent_name="out", conn_type="pub", data_interface=String, qos=100
    )
    node.spin(run_thread=True)
    connected = threading.Event()
    assert repeat_until(connected, lambda: connected.set() if pub.subscriber_count else None)
    for word in ("a", "cancelled", "bad", "b", "c"):
        pub.send(word)
    assert three.wait(EVENT_TIMEOUT)
    assert seen == ["a", "b", "c"]
    assert sub.error_count == 2
    assert sub.last_error == (
        "agent 'words' (sub std_msgs/msg/String): response_func raised ValueError: cannot use 'bad'"
    )


def test_async_handlers_run_on_the_users_loop(
    make_node: Any, user_loop: asyncio.AbstractEventLoop
) -> None:
    node = make_node(loop=user_loop)
    loops: list[asyncio.AbstractEventLoop] = []
    ticked = threading.Event()

    async def tick() -> int:
        loops.append(asyncio.get_running_loop())
        ticked.set()
        return 5

    timer = node.add_agent(conn_name="t", conn_type="timer", time_period=0.01, response_func=tick)
    node.spin(run_thread=True)
    assert ticked.wait(EVENT_TIMEOUT)
    assert loops[0] is user_loop
    got = threading.Event()
    assert repeat_until(got, lambda: got.set() if timer.get() == 5 else None)


def test_async_periodic_pub_publishes_what_it_returns(make_node: Any) -> None:
    node = make_node()
    heard = threading.Event()
    values: list[str] = []

    async def next_text() -> str:
        await asyncio.sleep(0)
        return "from a coroutine"

    node.add_agent(
        conn_name="periodic",
        conn_type="sub",
        data_interface=String,
        response_func=lambda value: (values.append(value), heard.set()),
    )
    node.add_agent(
        conn_name="periodic",
        agent_name="out",
        conn_type="pub",
        data_interface=String,
        time_period=0.01,
        response_func=next_text,
    )
    node.spin(run_thread=True)
    assert heard.wait(EVENT_TIMEOUT)
    assert values[0] == "from a coroutine"


def test_async_service_handler_answers_and_its_errors_still_answer(make_node: Any) -> None:
    node = make_node()

    async def switch(request: dict[str, Any]) -> dict[str, Any]:
        await asyncio.sleep(0.001)
        if not request["data"]:
            raise RuntimeError("motor jammed")
        return {"success": True, "message": "on"}

    node.add_agent(
        conn_name="motors", conn_type="service_server", data_interface=SetBool,
        response_func=switch,
    )  # fmt: skip
    client = node.add_agent(
        conn_name="motors", agent_name="client", conn_type="service_client",
        data_interface=SetBool, timeout=EVENT_TIMEOUT,
    )  # fmt: skip
    node.spin(run_thread=True)
    assert client.send({"data": True}) == {"success": True, "message": "on", "isdone": True}
    assert client.send({"data": False}) == {
        "success": False,
        "message": "RuntimeError: motor jammed",
        "isdone": True,
    }


def test_async_action_handlers_plain_and_generator(make_node: Any) -> None:
    node = make_node()

    async def plain(goal: dict[str, Any]) -> dict[str, Any]:
        await asyncio.sleep(0.001)
        if goal["order"] < 0:
            raise ValueError("negative order")
        return {"sequence": [goal["order"]]}

    async def stepwise(goal: dict[str, Any]) -> AsyncIterator[dict[str, Any]]:
        sequence: list[int] = []
        for step in range(goal["order"]):
            await asyncio.sleep(0)
            sequence.append(step)
            yield {"sequence": list(sequence)}

    node.add_agent(
        conn_name="plain", conn_type="action_server", data_interface=Fibonacci, response_func=plain
    )
    node.add_agent(
        conn_name="steps", conn_type="action_server", data_interface=Fibonacci,
        response_func=stepwise,
    )  # fmt: skip
    plain_client = node.add_agent(
        conn_name="plain", agent_name="plain_client", conn_type="action_client",
        data_interface=Fibonacci, timeout=EVENT_TIMEOUT,
    )  # fmt: skip
    steps_client = node.add_agent(
        conn_name="steps", agent_name="steps_client", conn_type="action_client",
        data_interface=Fibonacci, timeout=EVENT_TIMEOUT,
    )  # fmt: skip
    node.spin(run_thread=True)
    assert plain_client.send({"order": 3}) == {"sequence": [3], "isdone": True}
    aborted = plain_client.send({"order": -1})
    assert aborted["error"] == (
        "agent 'plain_client' (action_client test_msgs/action/Fibonacci): "
        "goal aborted by the server: ValueError: negative order"
    )
    # An async generator's result is its last yield.
    assert steps_client.send({"order": 3}) == {"sequence": [0, 1, 2], "isdone": True}


def test_send_async_from_a_users_loop(make_node: Any, user_loop: asyncio.AbstractEventLoop) -> None:
    node = make_node()
    node.add_agent(
        conn_name="ping", conn_type="service_server", data_interface=Trigger,
        response_func=lambda _request: {"success": True, "message": "pong"},
    )  # fmt: skip
    node.add_agent(
        conn_name="fib", conn_type="action_server", data_interface=Fibonacci,
        response_func=lambda goal: {"sequence": [goal["order"], 1]},
    )  # fmt: skip
    heard = threading.Event()
    node.add_agent(
        conn_name="news", conn_type="sub", data_interface=String,
        response_func=lambda _value: heard.set(),
    )  # fmt: skip
    service = node.add_agent(
        conn_name="ping", agent_name="ping_client", conn_type="service_client",
        data_interface=Trigger, timeout=EVENT_TIMEOUT,
    )  # fmt: skip
    action = node.add_agent(
        conn_name="fib", agent_name="fib_client", conn_type="action_client",
        data_interface=Fibonacci, timeout=EVENT_TIMEOUT,
    )  # fmt: skip
    pub = node.add_agent(
        conn_name="news", agent_name="news_out", conn_type="pub", data_interface=String
    )
    node.spin(run_thread=True)

    async def app() -> list[Any]:
        # Both calls wait together on this loop, which stays free meanwhile.
        return await asyncio.gather(service.send_async(), action.send_async({"order": 4}))

    assert _run(user_loop, app()) == [
        {"success": True, "message": "pong", "isdone": True},
        {"sequence": [4, 1], "isdone": True},
    ]
    assert repeat_until(heard, lambda: _run(user_loop, pub.send_async("hello")))


def test_send_async_times_out_without_blocking_the_loop(
    make_node: Any, user_loop: asyncio.AbstractEventLoop
) -> None:
    node = make_node()
    release = threading.Event()

    def slow(_goal: dict[str, Any]) -> Iterator[None]:
        while not release.wait(0.01):
            yield None
        return None

    node.add_agent(
        conn_name="slow", conn_type="action_server", data_interface=Fibonacci, response_func=slow
    )
    client = node.add_agent(
        conn_name="slow", agent_name="slow_client", conn_type="action_client",
        data_interface=Fibonacci, timeout=EVENT_TIMEOUT,
    )  # fmt: skip
    node.spin(run_thread=True)
    connected = threading.Event()
    assert repeat_until(connected, lambda: connected.set() if client.is_connected() else None)
    result = _run(user_loop, client.send_async({"order": 1}, timeout=0.2))
    release.set()
    assert result == {
        "isdone": False,
        "error": "agent 'slow_client' (action_client test_msgs/action/Fibonacci): "
        "no result within 0.2 s (goal canceled)",
    }


def test_async_action_client_callbacks(make_node: Any) -> None:
    node = make_node()
    accepted: list[bool] = []
    results: list[Any] = []
    done = threading.Event()

    async def on_accepted(ok: bool) -> None:
        await asyncio.sleep(0)
        accepted.append(ok)

    async def on_result(result: Any) -> None:
        await asyncio.sleep(0)
        results.append(result)
        done.set()

    node.add_agent(
        conn_name="fib", conn_type="action_server", data_interface=Fibonacci,
        response_func=lambda goal: {"sequence": [goal["order"]]},
    )  # fmt: skip
    client = node.add_agent(
        conn_name="fib", agent_name="fib_client", conn_type="action_client",
        data_interface=Fibonacci, timeout=EVENT_TIMEOUT, response_func=on_result,
        accepted_func=on_accepted,
    )  # fmt: skip
    node.spin(run_thread=True)
    returned = client.send({"order": 6})
    assert done.wait(EVENT_TIMEOUT)
    assert results == [returned] == [{"sequence": [6], "isdone": True}]
    # Each callback has its lane position: the acceptance ran before the result's callback.
    assert accepted == [True]


@pytest.mark.parametrize("shut_down_on", ["the loop's thread", "another thread"])
def test_shutdown_cancels_a_handler_awaiting_on_the_users_loop(
    make_node: Any, user_loop: asyncio.AbstractEventLoop, shut_down_on: str
) -> None:
    # The user's loop outlives the node: nothing but shutdown cancels what the node started on
    # it, and a service callback waiting for the handler would hold shutdown up (and the node
    # be destroyed under it). On the loop's own thread (a FastAPI lifespan's exit) the loop
    # cannot run anything until shutdown returns.
    node = make_node(loop=user_loop)
    started = threading.Event()
    cancelled = threading.Event()

    async def never_answers(_request: dict[str, Any]) -> dict[str, Any]:
        started.set()
        try:
            await asyncio.Event().wait()
        except asyncio.CancelledError:
            cancelled.set()
            raise
        return {"success": True}

    node.add_agent(
        conn_name="stuck", conn_type="service_server", data_interface=Trigger,
        response_func=never_answers,
    )  # fmt: skip
    client = node.add_agent(
        conn_name="stuck", agent_name="stuck_client", conn_type="service_client",
        data_interface=Trigger,
    )  # fmt: skip
    node.spin(run_thread=True)
    reply = client.send({}, block=False, timeout=EVENT_TIMEOUT)
    assert started.wait(EVENT_TIMEOUT)
    shut_down = threading.Event()

    def shut_down_now() -> None:
        node.shutdown()
        shut_down.set()

    if shut_down_on == "the loop's thread":
        user_loop.call_soon_threadsafe(shut_down_now)
    else:
        threading.Thread(target=shut_down_now).start()
    assert cancelled.wait(EVENT_TIMEOUT)
    assert shut_down.wait(EVENT_TIMEOUT)
    assert node.shutdown_event.is_set()
    # The node's own client gets its answer (failed: the node shut down) rather than hanging.
    assert reply.result(EVENT_TIMEOUT)["isdone"] is False


def test_a_coroutine_queued_before_shutdown_never_runs_after_it(
    make_node: Any, user_loop: asyncio.AbstractEventLoop
) -> None:
    # The user's loop is busy when the message arrives: the lane's first wake-up is still
    # queued on it at shutdown, so no task exists yet to cancel.
    node = make_node(loop=user_loop)
    ran: list[str] = []

    async def handler(value: str) -> None:
        ran.append(value)

    sub = node.add_agent(conn_name="lane", conn_type="sub", data_interface=String,
                         response_func=handler)  # fmt: skip
    pub = node.add_agent(conn_name="lane", agent_name="out", conn_type="pub", data_interface=String)
    node.spin(run_thread=True)
    matched = threading.Event()
    assert repeat_until(matched, lambda: matched.set() if pub.subscriber_count else None)
    busy, release = threading.Event(), threading.Event()
    user_loop.call_soon_threadsafe(lambda: (busy.set(), release.wait(EVENT_TIMEOUT)))
    assert busy.wait(EVENT_TIMEOUT)
    received = threading.Event()
    assert repeat_until(received, lambda: received.set() if sub.message_count else pub.send("x"))
    node.shutdown()
    release.set()
    for _ in range(3):  # a few turns of the loop: what was queued on it has run by then
        _run(user_loop, asyncio.sleep(0))
    assert ran == []


def test_shutdown_from_an_async_handler_on_pyconnects_loop_completes(make_node: Any) -> None:
    """The handler runs on the loop's own thread: shutdown cannot join that thread from there,
    so it starts on a thread of its own, and still goes all the way (node destroyed, context
    left, loop thread ended)."""
    node = make_node("async_stopper")
    raised: list[BaseException] = []
    called = threading.Event()

    async def tick() -> None:
        if called.is_set():
            return
        called.set()
        try:
            node.shutdown()
        except BaseException as error:
            raised.append(error)

    node.add_agent(conn_name="tick", conn_type="timer", time_period=0.01, response_func=tick)
    node.spin(run_thread=True)
    assert node.wait_for_shutdown(EVENT_TIMEOUT)
    assert raised == []
    assert not node.context.ok()
    loop_threads = [t for t in threading.enumerate() if t.name == "pyconnect-asyncio-async_stopper"]
    assert not any(thread.is_alive() for thread in loop_threads)


def test_an_async_service_handler_that_shuts_its_node_down_still_replies(
    make_node: Any,
) -> None:
    async def stop(_request: dict[str, Any]) -> dict[str, Any]:
        server_node.shutdown()
        return {"success": True, "message": "bye"}

    server_node, client = server_and_client(make_node, "async_stop", "service", Trigger, stop)
    assert client.send() == {"success": True, "message": "bye", "isdone": True}
    assert server_node.wait_for_shutdown(EVENT_TIMEOUT)


def test_an_async_goal_cancelled_by_shutdown_is_aborted_with_a_reason(make_node: Any) -> None:
    started = threading.Event()

    async def endless(_goal: dict[str, Any]) -> dict[str, Any]:
        started.set()
        await asyncio.Event().wait()
        return {"sequence": []}

    server_node, client = server_and_client(make_node, "async_goal", "action", Fibonacci, endless)
    result = client.send({"order": 1}, block=False)
    assert started.wait(EVENT_TIMEOUT)
    wait_for_the_result_request(server_node, "served")
    server_node.shutdown()
    outcome = result.result(EVENT_TIMEOUT * 2)
    assert outcome["isdone"] is False
    assert outcome["error"].endswith("goal aborted by the server: server is shutting down")


@pytest.mark.parametrize("kind", ["sub", "service_server"])
def test_sys_exit_in_an_async_handler_shuts_the_node_down(make_node: Any, kind: str) -> None:
    # As a plain handler's sys.exit() does; raised on the loop it used to end pyconnect's loop
    # (every later async handler dead) and leave the node running.
    node = make_node(f"async_exit_{kind}")

    async def leave(_value: Any) -> None:
        await asyncio.sleep(0)
        sys.exit(3)

    interface = String if kind == "sub" else Trigger
    agent = node.add_agent(
        conn_name="leave", conn_type=kind, data_interface=interface, response_func=leave
    )
    if kind == "sub":
        sender = node.add_agent(
            conn_name="leave", agent_name="out", conn_type="pub", data_interface=String
        )
        send: Any = lambda: sender.send("bye")  # noqa: E731
    else:
        sender = node.add_agent(
            conn_name="leave", agent_name="caller", conn_type="service_client",
            data_interface=Trigger,
        )  # fmt: skip
        send = lambda: sender.send(block=False, timeout=EVENT_TIMEOUT)  # noqa: E731
    node.spin(run_thread=True)
    assert repeat_until(node._stopped, send)
    assert node.wait_for_shutdown(EVENT_TIMEOUT)
    loop_threads = [t for t in threading.enumerate() if t.name == f"pyconnect-asyncio-{node.name}"]
    assert not any(thread.is_alive() for thread in loop_threads)
    if kind == "sub":
        assert agent.last_error == (
            "agent 'leave' (sub std_msgs/msg/String): response_func raised SystemExit: 3"
        )


def test_waiting_on_the_loop_from_its_own_thread_raises(make_node: Any) -> None:
    node = make_node()
    agent = node.add_agent(
        conn_name="t", conn_type="timer", time_period=60.0, response_func=lambda: None
    )

    async def inner() -> int:
        return 1

    async def on_the_loop() -> str:
        try:
            agent.wait_on_loop(inner())
        except PyconnectError as error:
            return str(error)
        return "(not refused)"

    assert _run(node.coroutines.loop, on_the_loop()) == (
        "agent 't' (timer): waiting for a coroutine on the thread of the asyncio loop that must "
        "run it would never end: await it instead"
    )


@pytest.mark.parametrize("ended", ["closed", "stopped"])
def test_async_handlers_on_a_user_loop_that_ended_fail_with_why(
    make_node: Any, ended: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The app's loop ended before the node: requests used to go unanswered (a stopped loop) or
    # fail unexplained, messages vanish without a word, coroutines were never awaited. (A
    # sub's calls wait for a loop not running, as one not started yet, up to the lane's limit.)
    monkeypatch.setattr(coroutines, "LANE_LIMIT", 2)
    loop = asyncio.new_event_loop()
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    node = make_node(f"ended_{ended}", loop=loop)

    async def answer(_request: dict[str, Any]) -> dict[str, Any]:
        return {"success": True, "message": "real answer"}

    async def fib(goal: dict[str, Any]) -> dict[str, Any]:
        return {"sequence": [goal["order"]]}

    async def on_text(_text: str) -> None:
        pass

    node.add_agent(
        conn_name="ask", conn_type="service_server", data_interface=Trigger, response_func=answer
    )
    node.add_agent(
        conn_name="fib", conn_type="action_server", data_interface=Fibonacci, response_func=fib
    )
    sub = node.add_agent(
        conn_name="txt", conn_type="sub", data_interface=String, response_func=on_text
    )
    node.spin(run_thread=True)
    loop.call_soon_threadsafe(loop.stop)
    thread.join(EVENT_TIMEOUT)
    if ended == "closed":
        loop.close()
    other = make_node(f"ended_{ended}_client")
    service = other.add_agent(
        conn_name="ask", conn_type="service_client", data_interface=Trigger, timeout=EVENT_TIMEOUT
    )
    action = other.add_agent(
        conn_name="fib", conn_type="action_client", data_interface=Fibonacci,
        timeout=EVENT_TIMEOUT,
    )  # fmt: skip
    pub = other.add_agent(conn_name="txt", conn_type="pub", data_interface=String)
    why = f"the asyncio loop given to CustomNode(loop=) is {'closed' if ended == 'closed' else 'not running'}"
    try:
        assert service.send() == {
            "success": False,
            "message": f"PyconnectError: {why}",
            "isdone": True,
        }
        assert action.send({"order": 1})["error"] == (
            "agent 'fib' (action_client test_msgs/action/Fibonacci): goal aborted by the server: "
            f"PyconnectError: {why}"
        )
        three = threading.Event()
        assert repeat_until(three, lambda: three.set() if sub.message_count >= 3 else pub.send("x"))
        # Reported once, with the reason, not once per message.
        assert sub.error_count == 1
        assert sub.last_error == (
            f"agent 'txt' (sub std_msgs/msg/String): response_func raised PyconnectError: {why}"
        )
    finally:
        node.shutdown()
        if not loop.is_closed():
            loop.close()
