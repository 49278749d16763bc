"""``Caller``: how a call that gets no response says why (timeout, server error, cancel)."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from pyconnect.transport.endpoints import CallCancel, Caller, CallFailed
from pyconnect.transport.interface_types import service_interface
from tests.transport.conftest import TIMEOUT, PeerFactory

SERVICE = "/trigger"


class StandIn:
    """A bare queryable on a caller's key: ``answer(query)`` replies, or (``None``) the query
    is held unanswered until the test ends; ``arrived`` is set by each query."""

    def __init__(self) -> None:
        self.answer: Callable[[Any], None] | None = None
        self.held: list[Any] = []
        self.arrived = threading.Event()

    def on_query(self, query: Any) -> None:
        if self.answer is None:
            self.held.append(query)
        else:
            self.answer(query)
            query.drop()  # the reply is final: the caller's query ends
        self.arrived.set()


@pytest.fixture
def caller_and_server(make_peer: PeerFactory) -> Iterator[tuple[Caller, StandIn]]:
    peer = make_peer("vision")
    caller = Caller(peer, SERVICE, service_interface("std_srvs/srv/Trigger"))
    server = StandIn()
    queryable = peer.session.declare_queryable(caller.key, server.on_query, complete=True)
    try:
        yield caller, server
    finally:
        queryable.undeclare()
        for query in server.held:
            query.drop()


def test_a_query_nobody_answers_ends_timed_out(caller_and_server: tuple[Caller, StandIn]) -> None:
    """zenoh ends it with an error reply of its own, "Timeout": no failure of the server."""
    caller, _server = caller_and_server
    with pytest.raises(CallFailed) as failure:
        caller.call(b"", time.monotonic() + 0.2)
    assert str(failure.value) == f"no response from {SERVICE} in time"
    assert failure.value.timed_out


def test_a_server_error_saying_timeout_is_no_timeout(
    caller_and_server: tuple[Caller, StandIn],
) -> None:
    caller, server = caller_and_server
    server.answer = lambda query: query.reply_err("Timeout")
    with pytest.raises(CallFailed) as failure:
        caller.call(b"", time.monotonic() + TIMEOUT)
    assert str(failure.value) == f"the server of {SERVICE} failed: Timeout"
    assert not failure.value.timed_out


def test_a_cancelled_call_ends_at_once(caller_and_server: tuple[Caller, StandIn]) -> None:
    caller, server = caller_and_server
    cancel = CallCancel()
    failures: list[CallFailed] = []

    def call() -> None:
        try:
            caller.call(b"", time.monotonic() + TIMEOUT, cancel=cancel)
        except CallFailed as failure:
            failures.append(failure)

    thread = threading.Thread(target=call)
    thread.start()
    assert server.arrived.wait(TIMEOUT)
    cancel.cancel()
    thread.join(TIMEOUT)  # not when the query would time out
    assert not thread.is_alive()
    assert [str(failure) for failure in failures] == [f"the call to {SERVICE} was cancelled"]
    assert not failures[0].timed_out
    with pytest.raises(CallFailed) as again:  # a call with a cancelled token is not sent
        caller.call(b"", time.monotonic() + TIMEOUT, cancel=cancel)
    assert str(again.value) == f"the call to {SERVICE} was cancelled"


def test_a_cancelled_call_without_zenohs_cancellation_ends_with_its_query(
    caller_and_server: tuple[Caller, StandIn], monkeypatch: pytest.MonkeyPatch
) -> None:
    """zenoh-python before its query cancellation (pyconnect takes eclipse-zenoh>=1.0) has no
    ``CancellationToken`` and no ``cancellation_token=``: every call raised AttributeError or
    TypeError. The query then runs to its timeout and is reported cancelled."""
    from pyconnect.transport import endpoints

    monkeypatch.setattr(endpoints, "_HAS_CANCELLATION", False)
    session = caller_and_server[0]._peer.session
    get = session.get

    def old_get(*args: Any, **options: Any) -> Any:
        assert "cancellation_token" not in options
        return get(*args, **options)

    monkeypatch.setattr(caller_and_server[0]._peer, "session", _SessionWithGet(session, old_get))
    caller, server = caller_and_server
    cancel = CallCancel()
    assert cancel.token is None
    server.answer = None  # held: only the timeout ends the query
    cancel.cancel()
    with pytest.raises(CallFailed) as failure:
        caller.call(b"", time.monotonic() + 0.2, cancel=cancel)
    assert str(failure.value) == f"the call to {SERVICE} was cancelled"


class _SessionWithGet:
    """A zenoh session whose ``get`` is replaced (zenoh's own type takes no new attribute)."""

    def __init__(self, session: Any, get: Callable[..., Any]) -> None:
        self._session = session
        self.get = get

    def __getattr__(self, name: str) -> Any:
        return getattr(self._session, name)


def test_a_timeout_reply_without_replier_id_is_read_as_zenohs_own() -> None:
    """``Reply.replier_id`` is unstable in zenoh-python: a reply without it is zenoh's own
    timeout, not an AttributeError."""
    from types import SimpleNamespace

    from pyconnect.transport import endpoints

    payload = SimpleNamespace(to_bytes=lambda: endpoints.ZENOH_TIMEOUT_REPLY)
    reply = SimpleNamespace(ok=None, err=SimpleNamespace(payload=payload))
    assert endpoints._is_query_timeout(reply, expiry=time.monotonic() + 60)
