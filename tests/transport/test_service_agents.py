"""A peer's service client: whatever goes wrong in a call is a failure dict, never an exception."""

from __future__ import annotations

import concurrent.futures
import logging
import math
import threading
from collections.abc import Iterator
from typing import Any

import pytest

from pyconnect.errors import PyconnectError
from pyconnect.transport import rmw_zenoh_keys as keys
from tests.transport.conftest import TIMEOUT, PeerFactory

SERVICE = "/trigger"
TYPE = "std_srvs/srv/Trigger"
AGENT = f"agent 'trigger' (service_client {TYPE})"


@pytest.fixture
def client_and_server(make_peer: PeerFactory) -> Iterator[tuple[Any, list[Any]]]:
    """A client and a stand-in server (a bare queryable with the server's token) whose
    ``answer(query)`` the test sets by appending it to the returned list."""
    peer = make_peer("vision")
    client = peer.add_agent(
        conn_name="trigger", conn_type="service_client", data_interface=TYPE, timeout=TIMEOUT
    )
    answers: list[Any] = []

    def on_query(query: Any) -> None:
        answers[-1](query)

    queryable = peer.session.declare_queryable(client.key, on_query, complete=True)
    token = peer.session.liveliness().declare_token(
        peer.entity_token(
            kind=keys.SERVICE,
            name=SERVICE,
            type_name=TYPE,
            type_hash=client.key.rsplit("/", 1)[1],  # "RIHS01_<hex>", as in the key
            qos=keys.qos_chunk(),
        )
    )
    try:
        yield client, answers
    finally:
        token.undeclare()
        queryable.undeclare()


def test_an_error_reply_that_is_not_utf8_fails_the_call(
    client_and_server: tuple[Any, list[Any]],
) -> None:
    client, answers = client_and_server
    answers.append(lambda query: query.reply_err(b"\xff\xfe bad"))
    failure = {
        "isdone": False,
        "error": f"{AGENT}: the server of {SERVICE} failed: \ufffd\ufffd bad",
    }
    assert client.send() == failure
    future = client.send(block=False)
    assert isinstance(future, concurrent.futures.Future)
    assert future.result(TIMEOUT) == failure


def test_an_unexpected_error_in_the_call_fails_it_and_is_reported(
    client_and_server: tuple[Any, list[Any]], monkeypatch: pytest.MonkeyPatch
) -> None:
    client, _answers = client_and_server

    def broken(payload: bytes, deadline: float | None, *, cancel: Any = None) -> bytes:
        raise RuntimeError("zenoh went wrong")

    monkeypatch.setattr(client._caller, "call", broken)
    failure = {
        "isdone": False,
        "error": f"{AGENT}: the call failed: RuntimeError: zenoh went wrong",
    }
    assert client.send() == failure
    assert client.send(block=False).result(TIMEOUT) == failure
    assert client.error_count == 2
    assert client.last_error == f"{AGENT}: call raised RuntimeError: zenoh went wrong"


def test_keyboard_interrupt_in_the_call_is_not_swallowed(
    client_and_server: tuple[Any, list[Any]], monkeypatch: pytest.MonkeyPatch
) -> None:
    client, _answers = client_and_server

    def interrupted(payload: bytes, deadline: float | None, *, cancel: Any = None) -> bytes:
        raise KeyboardInterrupt

    monkeypatch.setattr(client._caller, "call", interrupted)
    with pytest.raises(KeyboardInterrupt):
        client.send()


def shuts_down_after_the_graph_check(monkeypatch: pytest.MonkeyPatch, peer: Any) -> None:
    """The race made certain: ``peer`` shuts down between a call's graph check (a server is
    there) and its query, so zenoh refuses the query: "session closed"."""
    check = peer.wait_for_graph

    def check_then_shut_down(condition: Any, deadline: float | None) -> bool:
        found: bool = check(condition, deadline)
        peer.shutdown()
        return found

    monkeypatch.setattr(peer, "wait_for_graph", check_then_shut_down)


def set_bool_pair(make_peer: PeerFactory, handler: Any) -> tuple[Any, Any]:
    server_peer, client_peer = make_peer("robot"), make_peer("vision")
    server_peer.add_agent(
        conn_name="enable", conn_type="service_server", data_interface="std_srvs/srv/SetBool",
        response_func=handler,
    )  # fmt: skip
    client = client_peer.add_agent(
        conn_name="enable", conn_type="service_client", data_interface="std_srvs/srv/SetBool",
        timeout=TIMEOUT,
    )  # fmt: skip
    client_peer.wait_until_connected(timeout=TIMEOUT)
    return client_peer, client


SHUT_DOWN = {
    "isdone": False,
    "error": "agent 'enable' (service_client std_srvs/srv/SetBool): peer 'vision' is shut down",
}


def test_a_call_whose_peer_shuts_down_before_the_query_fails_as_shut_down(
    make_peer: PeerFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    client_peer, client = set_bool_pair(make_peer, lambda _request: {"success": True})
    shuts_down_after_the_graph_check(monkeypatch, client_peer)
    assert client.send({"data": True}) == SHUT_DOWN  # not "the call failed: ZError: ..."
    assert client.error_count == 0  # a shutdown is no error to log
    assert client.send({"data": True}) == SHUT_DOWN  # as any call after the shutdown


def test_a_call_in_flight_when_its_peer_shuts_down_fails_as_shut_down(
    make_peer: PeerFactory,
) -> None:
    """Closing the client's session ends its query unanswered: the server did not go away."""
    peers: list[Any] = []

    def shut_the_client_down(_request: Any) -> dict[str, Any]:
        peers[0].shutdown()  # on the server's thread: it runs on a thread of its own
        assert peers[0].wait_for_shutdown(TIMEOUT)
        return {"success": True}

    client_peer, client = set_bool_pair(make_peer, shut_the_client_down)
    peers.append(client_peer)
    assert client.send({"data": True}) == SHUT_DOWN  # not "the server ... went away ..."
    assert client.error_count == 0


def test_a_call_nobody_answers_in_time_times_out_as_such(
    client_and_server: tuple[Any, list[Any]],
) -> None:
    """zenoh ends the query at the timeout with an error reply of its own ("Timeout"): that
    is no failure of the server."""
    client, answers = client_and_server
    held: list[Any] = []
    answers.append(held.append)
    try:
        assert client.send(timeout=0.2) == {
            "isdone": False,
            "error": f"{AGENT}: no response from {SERVICE} within 0.2 s",
        }
    finally:
        for query in held:
            query.drop()


def test_a_server_error_saying_timeout_is_still_the_servers(
    client_and_server: tuple[Any, list[Any]],
) -> None:
    client, answers = client_and_server
    answers.append(lambda query: query.reply_err("Timeout"))
    assert client.send(timeout=TIMEOUT) == {
        "isdone": False,
        "error": f"{AGENT}: the server of {SERVICE} failed: Timeout",
    }


def test_cancelling_the_future_drops_the_call(
    make_peer: PeerFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    crashes: list[Any] = []
    monkeypatch.setattr(threading, "excepthook", crashes.append)
    handling, release = threading.Event(), threading.Event()

    def slow(_request: Any) -> dict[str, Any]:
        handling.set()
        release.wait(TIMEOUT)
        return {"success": True}

    _client_peer, client = set_bool_pair(make_peer, slow)
    try:
        before = set(threading.enumerate())
        future = client.send({"data": True}, block=False)
        [thread] = [t for t in set(threading.enumerate()) - before if t.name.endswith("-call")]
        assert handling.wait(TIMEOUT)
        assert future.cancel()
        thread.join(TIMEOUT)  # the call ends now, not when the server answers
        assert not thread.is_alive()
    finally:
        release.set()
    assert future.cancelled()
    assert crashes == []
    assert client.error_count == 0


TIMEOUT_WORDS = "timeout must be None or a finite number of seconds >= 0, got"
SET_BOOL = "std_srvs/srv/SetBool"


@pytest.mark.parametrize(
    ("timeout", "shown"), [("2", "'2'"), (-1, "-1"), (math.nan, "nan"), (True, "True")]
)
def test_a_client_refuses_a_timeout_that_is_not_one(
    make_peer: PeerFactory, timeout: object, shown: str
) -> None:
    peer = make_peer("vision")
    with pytest.raises(PyconnectError) as caught:
        peer.add_agent(
            conn_name="enable", conn_type="service_client", data_interface=SET_BOOL,
            timeout=timeout,
        )  # fmt: skip
    assert str(caught.value) == (
        f"agent 'enable' (service_client {SET_BOOL}): {TIMEOUT_WORDS} {shown}"
    )
    assert peer.agents == {}


def test_a_call_with_a_wrong_timeout_raises_before_its_request_is_sent(
    make_peer: PeerFactory,
) -> None:
    requests: list[Any] = []

    def handler(request: dict[str, Any]) -> dict[str, Any]:
        requests.append(request)
        return {"success": True, "message": "ok"}

    peer = make_peer("robot")
    peer.add_agent(
        conn_name="enable", conn_type="service_server", data_interface=SET_BOOL,
        response_func=handler,
    )  # fmt: skip
    client = peer.add_agent(
        conn_name="enable", agent_name="cli", conn_type="service_client",
        data_interface=SET_BOOL, timeout=TIMEOUT,
    )  # fmt: skip
    agent = f"agent 'cli' (service_client {SET_BOOL})"
    for call in (
        lambda: client.send({"data": False}, timeout="1"),
        lambda: client.send({"data": False}, timeout="1", block=False),
    ):
        with pytest.raises(PyconnectError) as caught:
            call()
        assert str(caught.value) == f"{agent}: send: {TIMEOUT_WORDS} '1'"
    client.timeout = -2.0  # changed after the agent was made: each call checks it again
    with pytest.raises(PyconnectError) as caught:
        client.send({"data": False})
    assert str(caught.value) == f"{agent}: send: {TIMEOUT_WORDS} -2.0"
    client.timeout = TIMEOUT
    assert client.send({"data": True}) == {"success": True, "message": "ok", "isdone": True}
    assert requests == [{"data": True}]


@pytest.mark.parametrize(
    ("type_name", "answer", "warned"),
    [
        (SET_BOOL, {"success": False, "message": "", "isdone": True}, True),
        ("std_srvs/srv/Empty", {"isdone": True}, False),  # nothing else to answer: no warning
    ],
)
def test_a_handler_returning_none_answers_the_default_response(
    make_peer: PeerFactory,
    caplog: pytest.LogCaptureFixture,
    type_name: str,
    answer: dict[str, Any],
    warned: bool,
) -> None:
    peer = make_peer("robot")
    peer.add_agent(
        conn_name="forgetful", conn_type="service_server", data_interface=type_name,
        response_func=lambda _request: None,
    )  # fmt: skip
    client = peer.add_agent(
        conn_name="forgetful", agent_name="cli", conn_type="service_client",
        data_interface=type_name, timeout=TIMEOUT,
    )  # fmt: skip
    with caplog.at_level(logging.WARNING, logger="pyconnect.transport"):
        assert client.send({}) == answer
        assert client.send({}) == answer
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    once = (
        f"agent 'forgetful' (service_server {type_name}): response_func returned None: "
        f"answering the default {type_name}_Response"
    )
    assert warnings == ([once] if warned else [])


def test_a_server_of_another_type_is_no_server_and_the_call_names_both_types(
    make_peer: PeerFactory,
) -> None:
    """A server of another type never sees the client's queries (its key differs): the client
    is not connected, and its call says why instead of "went away"."""
    from pyconnect.errors import ConnectionTimeout
    from tests.transport.conftest import wait_for

    server_peer, client_peer = make_peer("robot"), make_peer("laptop")
    server = server_peer.add_agent(
        conn_name="s",
        conn_type="service_server",
        data_interface="std_srvs/srv/SetBool",
        response_func=lambda request: {"success": True},
    )
    client = client_peer.add_agent(
        conn_name="s", conn_type="service_client", data_interface=TYPE, timeout=TIMEOUT
    )
    assert wait_for(lambda: client_peer.graph.count(kind=keys.SERVICE, name="/s") == 1)
    assert not client.is_connected()
    assert client.server_count == 0
    with pytest.raises(ConnectionTimeout, match="has another type"):
        client_peer.wait_until_connected(timeout=0.2)
    theirs = server.key.rsplit("/", 1)[1]
    ours = client.key.rsplit("/", 1)[1]
    assert client.send() == {
        "isdone": False,
        "error": "agent 's' (service_client std_srvs/srv/Trigger): the server of /s has another "
        f"type: expected std_srvs/srv/Trigger ({ours}), found std_srvs/srv/SetBool ({theirs})",
    }


def test_a_server_of_the_same_type_name_with_another_hash_is_no_server(
    make_peer: PeerFactory,
) -> None:
    from tests.transport.conftest import wait_for

    peer = make_peer("vision")
    client = peer.add_agent(
        conn_name="trigger", conn_type="service_client", data_interface=TYPE, timeout=TIMEOUT
    )
    other_hash = "RIHS01_" + "0" * 64
    token = peer.session.liveliness().declare_token(
        peer.entity_token(
            kind=keys.SERVICE,
            name=SERVICE,
            type_name=TYPE,
            type_hash=other_hash,
            qos=keys.qos_chunk(),
        )
    )
    try:
        assert wait_for(lambda: peer.graph.count(kind=keys.SERVICE, name=SERVICE) == 1)
        assert not client.is_connected()
        failure = client.send()
        assert failure["isdone"] is False
        assert f"found {TYPE} ({other_hash})" in failure["error"]
    finally:
        token.undeclare()
