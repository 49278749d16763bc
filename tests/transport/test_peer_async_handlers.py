"""``async def`` handlers on a peer run to completion on their agent's thread, as on CustomNode."""

from __future__ import annotations

import asyncio
import threading
from typing import Any

from tests.transport.conftest import TIMEOUT, PeerFactory, wait_for

SET_BOOL = "std_srvs/srv/SetBool"
FIBONACCI = "test_msgs/action/Fibonacci"


def test_an_async_sub_handler_is_awaited_in_order_on_one_loop(make_peer: PeerFactory) -> None:
    sender, receiver = make_peer("vision"), make_peer("robot")
    seen: list[int] = []
    loops: set[asyncio.AbstractEventLoop] = set()
    threads: set[str] = set()
    all_seen = threading.Event()

    async def on_count(value: int) -> None:
        await asyncio.sleep(0)  # a real suspension: the loop runs it, not a plain call
        loops.add(asyncio.get_running_loop())
        threads.add(threading.current_thread().name)
        seen.append(value)
        if len(seen) == 20:
            all_seen.set()

    sub = receiver.add_agent(
        conn_name="count",
        conn_type="sub",
        data_interface="std_msgs/msg/Int32",
        response_func=on_count,
        depth=100,
    )
    pub = sender.add_agent(conn_name="count", conn_type="pub", data_interface="std_msgs/msg/Int32")
    assert wait_for(lambda: pub.subscriber_count == 1)
    for value in range(20):
        pub.send(value)
    assert all_seen.wait(TIMEOUT)
    assert seen == list(range(20))
    assert threads == {"pyconnect-sub-count"}
    assert sub.error_count == 0
    (loop,) = loops  # one loop serves every call of the agent's thread...
    receiver.shutdown()
    assert loop.is_closed()  # ...and closes with it


def test_an_async_timer_gives_its_coroutine_result(make_peer: PeerFactory) -> None:
    peer = make_peer("robot")
    ticked = threading.Event()

    async def tick() -> str:
        await asyncio.sleep(0)
        ticked.set()
        return "tock"

    timer = peer.add_agent(
        conn_name="tick", conn_type="timer", time_period=0.01, response_func=tick
    )
    assert ticked.wait(TIMEOUT)
    assert wait_for(lambda: timer.get() == "tock")
    assert timer.error_count == 0


def test_an_async_service_handler_answers_and_its_error_is_reported(
    make_peer: PeerFactory,
) -> None:
    server_peer, client_peer = make_peer("robot"), make_peer("vision")

    async def handle(request: dict[str, Any]) -> dict[str, Any]:
        await asyncio.sleep(0)
        if not request["data"]:
            raise RuntimeError("refused")
        return {"success": True, "message": "async"}

    server = server_peer.add_agent(
        conn_name="enable", conn_type="service_server", data_interface=SET_BOOL,
        response_func=handle,
    )  # fmt: skip
    client = client_peer.add_agent(
        conn_name="enable", conn_type="service_client", data_interface=SET_BOOL, timeout=TIMEOUT
    )
    client_peer.wait_until_connected(timeout=TIMEOUT)
    assert client.send({"data": True}) == {"success": True, "message": "async", "isdone": True}
    assert client.send({"data": False}) == {
        "success": False,
        "message": "RuntimeError: refused",
        "isdone": True,
    }
    assert server.error_count == 1
    assert server.last_error == (
        f"agent 'enable' (service_server {SET_BOOL}): response_func raised RuntimeError: refused"
    )


def test_an_async_sub_handler_that_raises_is_reported_and_the_next_sample_handled(
    make_peer: PeerFactory,
) -> None:
    sender, receiver = make_peer("vision"), make_peer("robot")
    handled: list[str] = []
    second = threading.Event()

    async def on_text(text: str) -> None:
        await asyncio.sleep(0)
        handled.append(text)
        if text == "bad":
            raise ValueError("cannot use it")
        second.set()

    sub = receiver.add_agent(
        conn_name="chat", conn_type="sub", data_interface="std_msgs/msg/String",
        response_func=on_text,
    )  # fmt: skip
    pub = sender.add_agent(conn_name="chat", conn_type="pub", data_interface="std_msgs/msg/String")
    assert wait_for(lambda: pub.subscriber_count == 1)
    pub.send("bad")
    pub.send("good")
    assert second.wait(TIMEOUT)
    assert handled == ["bad", "good"]
    assert sub.error_count == 1
    assert sub.last_error == (
        "agent 'chat' (sub std_msgs/msg/String): response_func raised ValueError: cannot use it"
    )


def test_an_async_periodic_publisher_sends_its_coroutine_result(make_peer: PeerFactory) -> None:
    sender, receiver = make_peer("vision"), make_peer("robot")
    got = threading.Event()

    async def value() -> int:
        await asyncio.sleep(0)
        return 7

    receiver.add_agent(
        conn_name="beat", conn_type="sub", data_interface="std_msgs/msg/Int32",
        response_func=lambda number: got.set() if number == 7 else None,
    )  # fmt: skip
    pub = sender.add_agent(
        conn_name="beat", conn_type="pub", data_interface="std_msgs/msg/Int32",
        time_period=0.01, response_func=value,
    )  # fmt: skip
    assert got.wait(TIMEOUT)
    assert pub.error_count == 0


def test_async_action_client_callbacks_are_awaited(make_peer: PeerFactory) -> None:
    server_peer, client_peer = make_peer("robot"), make_peer("laptop")
    calls: list[tuple[str, Any]] = []
    last_feedback = threading.Event()

    def fibonacci(goal: dict[str, Any], publish_feedback: Any) -> dict[str, Any]:
        sequence = [0, 1]
        for _ in range(goal["order"]):
            sequence.append(sequence[-1] + sequence[-2])
            publish_feedback({"sequence": sequence})
        return {"sequence": sequence}

    async def on_accepted(accepted: bool) -> None:
        await asyncio.sleep(0)
        calls.append(("accepted", accepted))

    async def on_feedback(feedback: dict[str, Any]) -> None:
        await asyncio.sleep(0)
        if len(feedback["sequence"]) == 4:
            last_feedback.set()

    async def on_result(result: dict[str, Any]) -> None:
        await asyncio.sleep(0)
        calls.append(("result", result))

    server_peer.add_agent(
        conn_name="fib", conn_type="action_server", data_interface=FIBONACCI,
        response_func=fibonacci,
    )  # fmt: skip
    client = client_peer.add_agent(
        conn_name="fib", conn_type="action_client", data_interface=FIBONACCI,
        accepted_func=on_accepted, feedback_func=on_feedback, response_func=on_result,
    )  # fmt: skip
    client_peer.wait_until_connected(timeout=TIMEOUT)
    result = client.send({"order": 2}, timeout=TIMEOUT)
    assert result == {"sequence": [0, 1, 1, 2], "isdone": True}
    assert calls == [("accepted", True), ("result", result)]
    assert last_feedback.wait(TIMEOUT)
    assert client.error_count == 0


def test_a_shutdown_cancels_the_async_handlers_still_running(make_peer: PeerFactory) -> None:
    """As a CustomNode cancels its handlers' tasks: each handler's ``finally`` runs, its thread
    ends, nothing is reported as an error and a waiting action client hears why its goal ended
    (before, every agent's close waited out its 5 s join and left the coroutine suspended)."""
    server_peer, client_peer = make_peer("robot"), make_peer("laptop")
    started = {kind: threading.Event() for kind in ("sub", "timer", "pub", "service", "action")}
    cancelled: list[str] = []

    def handler(kind: str) -> Any:
        async def wait_forever(*_: Any) -> None:
            started[kind].set()
            try:
                await asyncio.sleep(3600)
            finally:
                cancelled.append(kind)

        return wait_forever

    agents = [
        server_peer.add_agent(
            conn_name="text", conn_type="sub", data_interface="std_msgs/msg/String",
            response_func=handler("sub"),
        ),
        server_peer.add_agent(
            conn_name="tick", conn_type="timer", time_period=0.01, response_func=handler("timer")
        ),
        server_peer.add_agent(
            conn_name="beat", conn_type="pub", data_interface="std_msgs/msg/Int32",
            time_period=0.01, response_func=handler("pub"),
        ),
        server_peer.add_agent(
            conn_name="enable", conn_type="service_server", data_interface=SET_BOOL,
            response_func=handler("service"),
        ),
        server_peer.add_agent(
            conn_name="fib", conn_type="action_server", data_interface=FIBONACCI,
            response_func=handler("action"),
        ),
    ]  # fmt: skip
    pub = client_peer.add_agent(
        conn_name="text", conn_type="pub", data_interface="std_msgs/msg/String"
    )
    service = client_peer.add_agent(
        conn_name="enable", conn_type="service_client", data_interface=SET_BOOL, timeout=TIMEOUT
    )
    action = client_peer.add_agent(
        conn_name="fib", conn_type="action_client", data_interface=FIBONACCI, timeout=TIMEOUT
    )
    client_peer.wait_until_connected(timeout=TIMEOUT)
    assert wait_for(lambda: pub.subscriber_count == 1)
    pub.send("hello")
    service.send({"data": True}, block=False)
    goal = action.send({"order": 3}, block=False)
    assert all(event.wait(TIMEOUT) for event in started.values())

    server_peer.shutdown()

    assert sorted(cancelled) == ["action", "pub", "service", "sub", "timer"]
    assert [agent.error_count for agent in agents] == [0] * 5
    result = goal.result(TIMEOUT)
    assert result["isdone"] is False
    assert "server is shutting down" in result["error"]


def test_an_async_stop_service_still_answers_after_asking_for_the_shutdown(
    make_peer: PeerFactory,
) -> None:
    """The shutdown cancels the handlers still running, but not the one that asked for it:
    a "stop" service's caller got "peer 'robot' is shutting down" instead of its answer."""
    server_peer, client_peer = make_peer("robot"), make_peer("laptop")

    async def stop(_request: dict[str, Any]) -> dict[str, Any]:
        server_peer.shutdown()
        await asyncio.sleep(0.05)  # a real suspension while the shutdown closes the agents
        return {"success": True, "message": "stopping"}

    server_peer.add_agent(
        conn_name="stop", conn_type="service_server", data_interface="std_srvs/srv/Trigger",
        response_func=stop,
    )  # fmt: skip
    client = client_peer.add_agent(
        conn_name="stop", conn_type="service_client", data_interface="std_srvs/srv/Trigger",
        timeout=TIMEOUT,
    )  # fmt: skip
    client_peer.wait_until_connected(timeout=TIMEOUT)
    assert client.send({}) == {"success": True, "message": "stopping", "isdone": True}
