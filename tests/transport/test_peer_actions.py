"""A peer's action agents: CustomNode's contract between two peers, on rcl_action's wire."""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest

from pyconnect.errors import PyconnectError
from pyconnect.transport import action_server
from pyconnect.transport import action_wire as aw
from tests.transport.conftest import PeerFactory, wait_for

TIMEOUT = 30.0
FIBONACCI = "test_msgs/action/Fibonacci"


def fibonacci(goal: dict[str, Any], publish_feedback: Any) -> dict[str, Any]:
    sequence = [0, 1]
    for _ in range(goal["order"]):
        sequence.append(sequence[-1] + sequence[-2])
        publish_feedback({"sequence": sequence})
    return {"sequence": sequence}


def pair(make_peer: PeerFactory, handler: Any, **client_options: Any) -> Any:
    server_peer, client_peer = make_peer("robot"), make_peer("laptop")
    server = server_peer.add_agent(
        conn_name="fib", conn_type="action_server", data_interface=FIBONACCI,
        response_func=handler,
    )  # fmt: skip
    client = client_peer.add_agent(
        conn_name="fib", conn_type="action_client", data_interface=FIBONACCI, **client_options
    )
    client_peer.wait_until_connected(timeout=TIMEOUT)
    return server, client


def new_thread(before: set[threading.Thread], name: str) -> threading.Thread:
    """The thread called ``name`` started since ``before`` (another test's may still end)."""
    [thread] = [t for t in threading.enumerate() if t.name == name and t not in before]
    return thread


def test_goal_feedback_and_result(make_peer: PeerFactory) -> None:
    feedback: list[Any] = []
    accepted: list[bool] = []
    results: list[Any] = []
    server, client = pair(
        make_peer, fibonacci, feedback_func=feedback.append, accepted_func=accepted.append,
        response_func=results.append,
    )  # fmt: skip
    result = client.send({"order": 4}, timeout=TIMEOUT)
    assert result == {"sequence": [0, 1, 1, 2, 3, 5], "isdone": True}
    assert accepted == [True]
    assert results == [result]
    assert client.get() == result
    # Feedback is published before the result, on another topic: wait for the last one.
    deadline = time.monotonic() + TIMEOUT
    while len(feedback) < 4 and time.monotonic() < deadline:
        time.sleep(0.01)
    assert feedback[-1] == {"sequence": [0, 1, 1, 2, 3, 5]}
    assert client.last_feedback == feedback[-1]
    assert server.goal_count == 1
    assert server.get() == {"order": 4}


def test_a_generator_handler_publishes_its_yields(make_peer: PeerFactory) -> None:
    def count(goal: dict[str, Any]) -> Iterator[dict[str, Any]]:
        for i in range(goal["order"]):
            yield {"sequence": [i]}
        return {"sequence": [goal["order"]]}

    feedback: list[Any] = []
    _server, client = pair(make_peer, count)
    future = client.send({"order": 3}, timeout=TIMEOUT, feedback_func=feedback.append, block=False)
    assert future.result(TIMEOUT) == {"sequence": [3], "isdone": True}


def test_a_raising_handler_aborts_with_its_text(make_peer: PeerFactory) -> None:
    def refuse(goal: dict[str, Any]) -> Any:
        raise ValueError(f"order {goal['order']} is too high")

    server, client = pair(make_peer, refuse)
    assert client.send({"order": 99}, timeout=TIMEOUT) == {
        "sequence": [],
        "isdone": False,
        "error": "agent 'fib' (action_client test_msgs/action/Fibonacci): goal aborted by the "
        "server: ValueError: order 99 is too high",
    }
    assert server.error_count == 1
    assert server.last_error == (
        "agent 'fib' (action_server test_msgs/action/Fibonacci): response_func raised "
        "ValueError: order 99 is too high"
    )


class EndlessGoal:
    """A generator handler that yields until it is stopped: ``started`` is set once it runs,
    ``closed`` once it is closed (canceled, or stopped by the shutdown)."""

    def __init__(self, pause: float = 0.0) -> None:
        self.started, self.closed = threading.Event(), threading.Event()
        self.pause = pause

    def __call__(self, goal: dict[str, Any]) -> Iterator[dict[str, Any]]:
        try:
            while True:
                self.started.set()
                yield {"sequence": [1]}
                if self.pause:
                    time.sleep(self.pause)
        finally:
            self.closed.set()


def test_cancel_stops_a_generator_between_yields(make_peer: PeerFactory) -> None:
    forever = EndlessGoal(pause=0.01)
    started, closed = forever.started, forever.closed
    _server, client = pair(make_peer, forever)
    future = client.send({"order": 1}, timeout=TIMEOUT, block=False)
    assert started.wait(TIMEOUT)
    deadline = time.monotonic() + TIMEOUT
    while client.cancel() == 0 and time.monotonic() < deadline:
        time.sleep(0.01)  # the goal is registered just after send() returned its future
    assert future.result(TIMEOUT) == {
        "sequence": [],
        "isdone": False,
        "error": "agent 'fib' (action_client test_msgs/action/Fibonacci): goal canceled",
    }
    assert closed.wait(TIMEOUT)


def test_a_timeout_cancels_the_goal(make_peer: PeerFactory) -> None:
    canceled = threading.Event()

    def slow(goal: dict[str, Any], publish_feedback: Any) -> dict[str, Any]:
        while not publish_feedback.cancel_requested:
            time.sleep(0.01)
        canceled.set()
        return {"sequence": [7]}

    _server, client = pair(make_peer, slow)
    result = client.send({"order": 1}, timeout=0.5)
    assert result == {
        "isdone": False,
        "error": "agent 'fib' (action_client test_msgs/action/Fibonacci): no result within "
        "0.5 s (goal canceled)",
    }
    assert canceled.wait(TIMEOUT)


def test_no_server_fails_like_custom_node(make_peer: PeerFactory) -> None:
    peer = make_peer("alone")
    client = peer.add_agent(conn_name="nobody", conn_type="action_client", data_interface=FIBONACCI)
    assert client.send({"order": 1}, timeout=0.2) == {
        "isdone": False,
        "error": "agent 'nobody' (action_client test_msgs/action/Fibonacci): no action server "
        "for nobody within 0.2 s",
    }
    assert not client.is_connected()


def test_a_server_needs_a_response_func_and_an_action_type(make_peer: PeerFactory) -> None:
    from pyconnect.errors import PyconnectError

    peer = make_peer("robot")
    with pytest.raises(PyconnectError) as missing:
        peer.add_agent(conn_name="fib", conn_type="action_server", data_interface=FIBONACCI)
    assert str(missing.value) == (
        "agent 'fib' (action_server test_msgs/action/Fibonacci): an 'action_server' agent "
        "needs a response_func"
    )
    with pytest.raises(PyconnectError) as wrong:
        peer.add_agent(
            conn_name="x", conn_type="action_client", data_interface="std_srvs/srv/SetBool"
        )
    assert str(wrong.value) == (
        "agent 'x' (action_client): std_srvs/srv/SetBool: expected a action type, got a "
        "service type"
    )


def test_a_goal_that_ends_after_its_server_shut_down_raises_nothing(
    make_peer: PeerFactory,
) -> None:
    running, release, ended = threading.Event(), threading.Event(), threading.Event()

    def wait(goal: dict[str, Any], publish_feedback: Any) -> dict[str, Any]:
        running.set()
        release.wait(TIMEOUT)
        try:
            publish_feedback({"sequence": [1]})
        finally:
            ended.set()
        return {"sequence": [2]}

    server, client = pair(make_peer, wait)
    future = client.send({"order": 1}, timeout=TIMEOUT, block=False)
    assert running.wait(TIMEOUT)
    server.peer.shutdown()
    release.set()
    assert ended.wait(TIMEOUT)
    deadline = time.monotonic() + TIMEOUT
    while not all(goal.response is not None for goal in server._goals.values()):
        assert time.monotonic() < deadline
        time.sleep(0.01)
    # Still running when close's timeout ran out: aborted as CustomNode does, and what the
    # handler returned afterwards is dropped.
    assert future.result(TIMEOUT) == {
        "sequence": [],
        "isdone": False,
        "error": f"agent 'fib' (action_client {FIBONACCI}): goal aborted by the server: "
        "server is shutting down",
    }


@pytest.mark.parametrize("answer", ["goal", "result"])
def test_a_malformed_answer_fails_the_goal_like_any_other(
    make_peer: PeerFactory, monkeypatch: pytest.MonkeyPatch, answer: str
) -> None:
    """A goal or result response that is not CDR of its type: {'isdone': False, ...}."""
    from pyconnect.transport.action_server import ActionServerAgent

    method = "_on_goal" if answer == "goal" else "_on_result_request"
    monkeypatch.setattr(
        ActionServerAgent, method, lambda _self, request: request.reply(b"\xff" * 12)
    )
    _server, client = pair(make_peer, fibonacci)
    what = "the goal response" if answer == "goal" else "the result"
    part = "SendGoal_Response" if answer == "goal" else "GetResult_Response"
    assert client.send({"order": 2}, timeout=TIMEOUT) == {
        "isdone": False,
        "error": f"agent 'fib' (action_client {FIBONACCI}): could not decode {what}: "
        f"{FIBONACCI}_{part}: unsupported CDR encapsulation ffff (expected 0001 little-endian "
        "or 0000 big-endian XCDR1)",
    }
    assert client.error_count == 1


def test_a_raising_decode_func_fails_the_goal_naming_the_agent_once(
    make_peer: PeerFactory,
) -> None:
    def unreadable(_msg: Any) -> Any:
        raise ValueError("cannot read this result")

    _server, client = pair(make_peer, fibonacci, decode_func=unreadable)
    assert client.send({"order": 1}, timeout=TIMEOUT) == {
        "isdone": False,
        "error": f"agent 'fib' (action_client {FIBONACCI}): could not decode the result: "
        "decode_func raised ValueError: cannot read this result",
    }
    assert client.error_count == 1


SHUT_DOWN = {
    "isdone": False,
    "error": f"agent 'fib' (action_client {FIBONACCI}): peer 'laptop' is shut down",
}


def test_a_goal_whose_peer_shuts_down_before_it_is_sent_fails_as_shut_down(
    make_peer: PeerFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The peer shuts down between the goal's graph check and its send_goal query (zenoh then
    refuses the query: "session closed"): the failure of a goal sent after the shutdown."""
    _server, client = pair(make_peer, fibonacci)
    check = client.peer.wait_for_graph

    def check_then_shut_down(condition: Any, deadline: float | None) -> bool:
        found: bool = check(condition, deadline)
        client.peer.shutdown()
        return found

    monkeypatch.setattr(client.peer, "wait_for_graph", check_then_shut_down)
    assert client.send({"order": 1}, timeout=TIMEOUT) == SHUT_DOWN
    assert client.error_count == 0  # not "could not decode the goal response: session closed"
    assert client.send({"order": 1}, timeout=TIMEOUT) == SHUT_DOWN


def test_a_goal_whose_peer_shuts_down_before_the_result_request_fails_as_shut_down(
    make_peer: PeerFactory,
) -> None:
    """accepted_func runs between send_goal and get_result: a shutdown there made zenoh's
    "session closed" escape send()."""
    peers: list[Any] = []
    _server, client = pair(make_peer, fibonacci, accepted_func=lambda _ok: peers[0].shutdown())
    peers.append(client.peer)
    assert client.send({"order": 1}, timeout=TIMEOUT) == SHUT_DOWN
    assert client.error_count == 0


def test_a_goal_in_flight_when_its_peer_shuts_down_fails_as_shut_down(
    make_peer: PeerFactory,
) -> None:
    """Closing the client's session ends its pending call (the result request, or the goal
    request if its answer is still on the way) unanswered: not the server's doing."""
    peers: list[Any] = []

    def shut_the_client_down(goal: dict[str, Any], publish_feedback: Any) -> dict[str, Any]:
        peers[0].shutdown()  # on the server's thread: it runs on a thread of its own
        assert peers[0].wait_for_shutdown(TIMEOUT)
        return {"sequence": [1]}

    _server, client = pair(make_peer, shut_the_client_down)
    peers.append(client.peer)
    assert client.send({"order": 1}, timeout=TIMEOUT) == SHUT_DOWN
    assert client.error_count == 0
    assert client.last_error is None


def test_a_zenoh_error_on_a_peer_still_running_fails_the_goal_naming_the_call(
    make_peer: PeerFactory,
) -> None:
    """zenoh refusing the query is a failed call, not an undecodable answer."""
    _server, client = pair(make_peer, fibonacci)
    client.peer.session.close()  # under the peer: it does not know it is shut down
    assert client.peer.ok()
    assert client.send({"order": 1}, timeout=TIMEOUT) == {
        "isdone": False,
        "error": f"agent 'fib' (action_client {FIBONACCI}): the call to "
        "/fib/_action/send_goal failed: session closed",
    }


# -- shutdown: CustomNode's contract (a finished goal succeeds, a running one is aborted) -------


def test_a_goal_whose_handler_returns_during_shutdown_succeeds(
    make_peer: PeerFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    running, release = threading.Event(), threading.Event()

    def plain(goal: dict[str, Any]) -> dict[str, Any]:
        running.set()
        release.wait(TIMEOUT)
        return {"sequence": [1, 2, 3]}

    server, client = pair(make_peer, plain)
    before = set(threading.enumerate())
    future = client.send({"order": 1}, timeout=TIMEOUT, block=False)
    assert running.wait(TIMEOUT)
    goal = new_thread(before, "pyconnect-goal-fib")
    join = goal.join

    def release_then_join(timeout: float | None = None) -> None:
        release.set()  # the handler returns while its server waits for it at shutdown
        join(timeout)

    monkeypatch.setattr(goal, "join", release_then_join)
    server.peer.shutdown()
    assert release.is_set()
    assert future.result(TIMEOUT) == {"sequence": [1, 2, 3], "isdone": True}


def test_a_generator_goal_running_at_shutdown_is_aborted_as_shutting_down(
    make_peer: PeerFactory,
) -> None:
    forever = EndlessGoal()
    started, closed = forever.started, forever.closed
    server, client = pair(make_peer, forever)
    future = client.send({"order": 1}, timeout=TIMEOUT, block=False)
    assert started.wait(TIMEOUT)
    server.peer.shutdown()  # stops the generator at its next yield
    assert closed.is_set()
    assert future.result(TIMEOUT) == {
        "sequence": [],
        "isdone": False,
        "error": f"agent 'fib' (action_client {FIBONACCI}): goal aborted by the server: "
        "server is shutting down",
    }


def test_a_stop_action_that_shuts_its_own_peer_down_sends_its_result(
    make_peer: PeerFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The README's "stop" handler on an action: its result arrives, as a stop service's reply
    does, even when the client asks for it only after the goal ended (the server waits)."""
    peers: list[Any] = []

    def stop(goal: dict[str, Any]) -> dict[str, Any]:
        peers[0].shutdown()  # on the goal's thread: the shutdown runs on a thread of its own
        return {"sequence": [7]}

    server, client = pair(make_peer, stop)
    peers.append(server.peer)
    ask = client._get_result.call

    def ask_once_the_goal_ended(payload: bytes, deadline: float | None) -> bytes:
        assert wait_for(lambda: all(goal.response for goal in server._goals.values()))
        result: bytes = ask(payload, deadline)
        return result

    monkeypatch.setattr(client._get_result, "call", ask_once_the_goal_ended)
    assert client.send({"order": 1}, timeout=TIMEOUT) == {"sequence": [7], "isdone": True}
    assert server.peer.wait_for_shutdown(TIMEOUT)


# -- the future of send(block=False) --------------------------------------------------------


def test_cancelling_the_future_cancels_the_goal(
    make_peer: PeerFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    forever = EndlessGoal()
    started, closed = forever.started, forever.closed
    crashes: list[Any] = []
    monkeypatch.setattr(threading, "excepthook", crashes.append)

    results: list[Any] = []
    server, client = pair(make_peer, forever, response_func=results.append)
    before = set(threading.enumerate())
    future = client.send({"order": 1}, timeout=TIMEOUT, block=False)
    thread = new_thread(before, "pyconnect-fib-goal")
    assert started.wait(TIMEOUT)
    assert future.cancel()
    assert closed.wait(TIMEOUT)  # the server canceled the goal
    thread.join(TIMEOUT)
    assert not thread.is_alive()
    assert future.cancelled()
    assert [goal.status for goal in server._goals.values()] == [aw.CANCELED]
    assert crashes == []
    assert client.last_error is None
    assert results == []  # nobody waits for this outcome any more


def test_cancelling_the_future_at_once_leaves_no_goal_running(
    make_peer: PeerFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Cancelled before the goal was sent or accepted: it is never sent, or canceled once
    accepted (a goal left running would keep the client's thread waiting for ever)."""
    crashes: list[Any] = []
    monkeypatch.setattr(threading, "excepthook", crashes.append)

    server, client = pair(make_peer, EndlessGoal())
    before = set(threading.enumerate())
    future = client.send({"order": 1}, block=False)
    thread = new_thread(before, "pyconnect-fib-goal")
    assert future.cancel()
    thread.join(TIMEOUT)
    assert not thread.is_alive()
    assert all(goal.status == aw.CANCELED for goal in server._goals.values())
    assert crashes == []
    assert client.last_error is None


# -- timeouts ------------------------------------------------------------------------------


def test_a_goal_request_nobody_answers_times_out_as_such(
    make_peer: PeerFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    """zenoh ends the send_goal query at the timeout with an error reply of its own: that is
    no failure of the server."""
    from pyconnect.transport.action_server import ActionServerAgent

    held: list[Any] = []
    monkeypatch.setattr(ActionServerAgent, "_on_goal", lambda _self, request: held.append(request))
    _server, client = pair(make_peer, fibonacci)
    try:
        assert client.send({"order": 1}, timeout=0.2) == {
            "isdone": False,
            "error": f"agent 'fib' (action_client {FIBONACCI}): no response from the action "
            "server within 0.2 s",
        }
    finally:
        for request in held:
            request.reply_error("test over")


TIMEOUT_WORDS = "timeout must be None or a finite number of seconds >= 0, got"
CLIENT = f"agent 'fib' (action_client {FIBONACCI})"


@pytest.mark.parametrize(("timeout", "shown"), [("2", "'2'"), (-0.5, "-0.5"), (math.inf, "inf")])
def test_a_client_refuses_a_timeout_that_is_not_one(
    make_peer: PeerFactory, timeout: object, shown: str
) -> None:
    peer = make_peer("laptop")
    with pytest.raises(PyconnectError) as caught:
        peer.add_agent(
            conn_name="fib", conn_type="action_client", data_interface=FIBONACCI, timeout=timeout
        )
    assert str(caught.value) == f"{CLIENT}: {TIMEOUT_WORDS} {shown}"
    assert peer.agents == {}


def test_a_goal_with_a_wrong_timeout_raises_before_it_is_sent(make_peer: PeerFactory) -> None:
    server, client = pair(make_peer, lambda goal: {"sequence": [goal["order"]]}, timeout=TIMEOUT)
    for call in (
        lambda: client.send({"order": 2}, timeout="1"),
        lambda: client.send({"order": 2}, timeout="1", block=False),
    ):
        with pytest.raises(PyconnectError) as caught:
            call()
        assert str(caught.value) == f"{CLIENT}: send: {TIMEOUT_WORDS} '1'"
    assert client.send({"order": 3}) == {"sequence": [3], "isdone": True}
    assert server.goal_count == 1  # no goal of the wrong calls was sent


@pytest.mark.parametrize("style", ["function", "generator"])
def test_a_handler_returning_none_succeeds_with_the_default_result_and_one_warning(
    make_peer: PeerFactory, caplog: pytest.LogCaptureFixture, style: str
) -> None:
    def forgetful(_goal: dict[str, Any]) -> None:
        return None

    def forgetful_generator(_goal: dict[str, Any]) -> Iterator[dict[str, Any]]:
        yield {"sequence": [1]}

    handler = forgetful if style == "function" else forgetful_generator
    _server, client = pair(make_peer, handler, timeout=TIMEOUT)
    with caplog.at_level(logging.WARNING, logger="pyconnect.transport"):
        assert client.send({"order": 2}) == {"sequence": [], "isdone": True}
        assert client.send({"order": 2}) == {"sequence": [], "isdone": True}
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert warnings == [
        f"agent 'fib' (action_server {FIBONACCI}): response_func returned None: answering the "
        f"default {FIBONACCI}_Result"
    ]


def test_cancel_cancels_goals_still_waiting_for_their_server(make_peer: PeerFactory) -> None:
    """cancel() looked at goals already sent only: a goal waiting for the server was sent,
    and ran, once the server appeared."""
    client_peer = make_peer("early")
    client = client_peer.add_agent(
        conn_name="fib", conn_type="action_client", data_interface=FIBONACCI, timeout=TIMEOUT
    )
    future = client.send({"order": 3}, block=False)
    assert wait_for(lambda: client._queued)
    assert client.cancel() == 1
    outcome = future.result(TIMEOUT)
    assert outcome["isdone"] is False
    assert outcome["error"].endswith("goal canceled")
    executed: list[int] = []
    make_peer("late_server").add_agent(
        conn_name="fib", conn_type="action_server", data_interface=FIBONACCI,
        response_func=lambda goal: executed.append(goal["order"]) or {"sequence": [1]},
    )  # fmt: skip
    client_peer.wait_until_connected(TIMEOUT)
    assert client.send({"order": 1})["sequence"] == [1]
    assert executed == [1]


def test_a_server_of_another_action_type_is_no_server_and_the_goal_names_both(
    make_peer: PeerFactory,
) -> None:
    from pyconnect.errors import ConnectionTimeout

    server_peer, client_peer = make_peer("robot"), make_peer("laptop")
    server_peer.add_agent(
        conn_name="act", conn_type="action_server", data_interface=FIBONACCI,
        response_func=fibonacci,
    )  # fmt: skip
    client = client_peer.add_agent(
        conn_name="act",
        conn_type="action_client",
        data_interface="test_msgs/action/NestedMessage",
        timeout=TIMEOUT,
    )
    assert wait_for(lambda: client_peer.graph.count(kind="SS", name="/act/_action/send_goal") == 1)
    assert not client.is_connected()
    with pytest.raises(ConnectionTimeout, match="has another type"):
        client_peer.wait_until_connected(timeout=0.2)
    outcome = client.send({})
    assert outcome["isdone"] is False
    assert "expected test_msgs/action/NestedMessage_SendGoal (RIHS01_" in outcome["error"]
    assert "found test_msgs/action/Fibonacci_SendGoal (RIHS01_" in outcome["error"]


def test_a_goal_whose_result_nobody_asks_for_does_not_hold_the_shutdown(
    make_peer: PeerFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A client may send a goal and never ask for its result: the server's close waited its
    whole 5 s for that request after any goal that had ended in the last 5 s."""
    monkeypatch.setattr(action_server, "RESULT_GRACE", 0.05)
    server, client = pair(make_peer, lambda goal: {"sequence": [1]})

    def never_asked(payload: bytes, deadline: float | None) -> bytes:
        raise RuntimeError("this client does not ask")

    monkeypatch.setattr(client._get_result, "call", never_asked)
    with pytest.raises(RuntimeError, match="does not ask"):
        client.send({"order": 1}, timeout=TIMEOUT)
    assert wait_for(lambda: all(goal.ended for goal in server._goals.values()))
    began = time.monotonic()
    server.peer.shutdown()
    assert time.monotonic() - began < 3.0  # generous: the bug took 5 s
