"""Services keep every request: a burst beyond the QoS depth is answered in full, never dropped."""

from __future__ import annotations

import threading
import time
from typing import Any

import pytest

from pyconnect.transport.endpoints import Caller, CallFailed, Request, Server
from pyconnect.transport.interface_types import service_interface
from pyconnect.transport.peer_agent import Inbox
from tests.transport.conftest import TIMEOUT, PeerFactory, wait_for

BURST = 30  # three times the depth of 10 the servers used to keep


class FirstCallBlocks:
    """A handler whose first call waits for ``release``: what arrives meanwhile has to queue."""

    def __init__(self, answer: Any) -> None:
        self.started = threading.Event()
        self.release = threading.Event()
        self.calls = 0
        self._answer = answer

    def __call__(self, *arguments: Any) -> Any:
        self.calls += 1
        if not self.started.is_set():
            self.started.set()
            assert self.release.wait(TIMEOUT)
        return self._answer(*arguments)


def test_a_service_server_answers_every_request_of_a_burst(make_peer: PeerFactory) -> None:
    server_peer, client_peer = make_peer("robot"), make_peer("vision")
    handler = FirstCallBlocks(lambda request: {"success": request["data"], "message": "ok"})
    server = server_peer.add_agent(
        conn_name="sb",
        conn_type="service_server",
        data_interface="std_srvs/srv/SetBool",
        response_func=handler,
    )
    client = client_peer.add_agent(
        conn_name="sb", conn_type="service_client", data_interface="std_srvs/srv/SetBool"
    )
    client_peer.wait_until_connected(timeout=TIMEOUT)
    futures = [client.send({"data": True}, block=False, timeout=TIMEOUT) for _ in range(BURST)]
    assert handler.started.wait(TIMEOUT)
    # All but the one in the handler wait in the server's queue; a keep-last 10 held 10.
    assert wait_for(lambda: server.waiting_requests == BURST - 1)
    handler.release.set()
    results = [future.result(TIMEOUT) for future in futures]
    assert results == [{"success": True, "message": "ok", "isdone": True}] * BURST
    assert server.request_count == BURST


def test_an_action_server_accepts_every_goal_of_a_burst(
    make_peer: PeerFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    from pyconnect.transport.action_server import ActionServerAgent

    on_goal = FirstCallBlocks(ActionServerAgent._on_goal)

    def blocking_on_goal(self: ActionServerAgent, request: Request) -> None:  # a method: bound
        on_goal(self, request)

    monkeypatch.setattr(ActionServerAgent, "_on_goal", blocking_on_goal)
    server_peer, client_peer = make_peer("robot"), make_peer("laptop")
    server: Any = server_peer.add_agent(
        conn_name="fib",
        conn_type="action_server",
        data_interface="test_msgs/action/Fibonacci",
        response_func=lambda goal: {"sequence": [goal["order"]]},
    )
    client = client_peer.add_agent(
        conn_name="fib", conn_type="action_client", data_interface="test_msgs/action/Fibonacci"
    )
    client_peer.wait_until_connected(timeout=TIMEOUT)
    futures = [client.send({"order": n}, block=False, timeout=TIMEOUT) for n in range(BURST)]
    assert on_goal.started.wait(TIMEOUT)
    send_goal = server._servers[0]
    assert wait_for(lambda: send_goal.waiting == BURST - 1)
    on_goal.release.set()
    results = [future.result(TIMEOUT) for future in futures]
    assert results == [{"sequence": [n], "isdone": True} for n in range(BURST)]
    assert server.goal_count == BURST


def test_a_keep_all_inbox_keeps_every_item_and_discards_what_waits_at_close() -> None:
    handled: list[int] = []
    discarded: list[int] = []
    handler = FirstCallBlocks(handled.append)
    inbox: Inbox[int] = Inbox("test-inbox", None, handler, discard=discarded.append)
    for item in range(BURST):
        inbox.put(item)
    assert handler.started.wait(TIMEOUT)
    assert (inbox.waiting, inbox.dropped) == (BURST - 1, 0)
    closer = threading.Thread(target=inbox.close)
    closer.start()
    assert wait_for(lambda: inbox.closed)
    handler.release.set()
    closer.join(TIMEOUT)
    assert not closer.is_alive()
    assert handled == [0]  # the one in hand is finished; the rest is not handed on
    inbox.put(BURST)  # arrives after close
    assert discarded == list(range(1, BURST + 1))


def test_a_request_answered_with_an_error_fails_the_call_with_its_text(
    make_peer: PeerFactory,
) -> None:
    peer = make_peer("robot")
    interface = service_interface("std_srvs/srv/Trigger")

    def refuse(request: Request) -> None:
        request.reply_error("request dropped: the server is shutting down")

    server = Server(peer, "/trigger", interface, refuse)
    caller = Caller(peer, "/trigger", interface)
    try:
        assert peer.wait_for_graph(lambda: caller.server_count == 1, time.monotonic() + TIMEOUT)
        with pytest.raises(CallFailed) as failed:
            caller.call(interface.request.from_dict({}), time.monotonic() + TIMEOUT)
        assert str(failed.value) == (
            "the server of /trigger failed: request dropped: the server is shutting down"
        )
    finally:
        caller.close()
        server.close()
