"""A peer's service client: whatever goes wrong in a call is a failure dict, never an exception."""

from __future__ import annotations

import concurrent.futures
from collections.abc import Iterator
from typing import Any

import pytest

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
            type_hash=client.key.rsplit("/", 1)[1].removeprefix("RIHS01_"),
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

    def broken(payload: bytes, deadline: float | None) -> bytes:
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

    def interrupted(payload: bytes, deadline: float | None) -> bytes:
        raise KeyboardInterrupt

    monkeypatch.setattr(client._caller, "call", interrupted)
    with pytest.raises(KeyboardInterrupt):
        client.send()
