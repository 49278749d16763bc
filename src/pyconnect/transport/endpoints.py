"""One rmw_zenoh entity each, without an agent around it: what services and actions are made of.

A service agent is one ``Server`` or one ``Caller``; rcl_action builds an action of three
services and two topics, so a peer's action agents are made of the same entities, each with its
token (see rmw_zenoh_keys for the formats): ``Writer`` (publisher), ``Reader`` (subscription),
``Server`` (a queryable answering each query once, possibly later and from another thread) and
``Caller`` (a client sending one query per call, which a ``CallCancel`` ends early).
"""

# zenoh's stubs leave undeclare() and close() unannotated.
# mypy: disable-error-code="no-untyped-call"

from __future__ import annotations

import contextlib
import struct
import threading
import time
from collections.abc import Callable
from typing import Any

import zenoh

from pyconnect.transport import rmw_zenoh_keys as keys
from pyconnect.transport.interface_types import MessageInterface, ServiceInterface
from pyconnect.transport.peer_agent import Inbox, Peer

# A call without a timeout still ends: zenoh needs one; a day is "never" here.
NO_TIMEOUT = 86400.0

# The error reply zenoh itself delivers when a query's timeout ends it.
ZENOH_TIMEOUT_REPLY = b"Timeout"


class Writer:
    """A publisher of ``interface`` on ``name`` (attachment per sample, token ``MP``)."""

    def __init__(
        self,
        peer: Peer,
        name: str,
        interface: MessageInterface,
        *,
        depth: int = 10,
        durability: str = "volatile",
    ) -> None:
        self.codec = interface.codec
        self.key = keys.data_key(peer.domain_id, name, interface.type_name, interface.type_hash)
        self.token_key = peer.entity_token(
            kind=keys.PUBLISHER,
            name=name,
            type_name=interface.type_name,
            type_hash=interface.type_hash,
            qos=keys.qos_chunk(depth=depth, durability=durability),
        )
        self.gid = keys.gid_of(self.token_key)
        self._sequence = 0
        self._lock = threading.Lock()
        self._closed = False
        self._publisher = peer.session.declare_publisher(
            self.key, reliability=zenoh.Reliability.RELIABLE
        )
        self._token = peer.session.liveliness().declare_token(self.token_key)

    @property
    def matched(self) -> bool:
        """Whether zenoh routes this publisher's samples to any subscriber now."""
        status: Any = self._publisher.matching_status  # a MatchingStatus (stubs say bool)
        return bool(getattr(status, "matching", status))

    def put(self, payload: bytes) -> None:
        """Publish ``payload``; nothing once closed (a goal may end after its server did)."""
        with self._lock:
            if self._closed:
                return
            self._sequence += 1
            attachment = keys.pack_attachment(self._sequence, time.time_ns(), self.gid)
            self._publisher.put(payload, attachment=attachment)

    def close(self) -> None:
        with self._lock:
            self._closed = True
        for entity in (self._token, self._publisher):
            with contextlib.suppress(Exception):
                entity.undeclare()


class Reader:
    """A subscription to ``name``: ``handle(payload)`` runs on one thread of its own."""

    def __init__(
        self,
        peer: Peer,
        name: str,
        interface: MessageInterface,
        handle: Callable[[bytes], None],
        *,
        depth: int = 10,
        durability: str = "volatile",
        thread_name: str = "reader",
    ) -> None:
        self.token_key = peer.entity_token(
            kind=keys.SUBSCRIPTION,
            name=name,
            type_name=interface.type_name,
            type_hash=interface.type_hash,
            qos=keys.qos_chunk(depth=depth, durability=durability),
        )
        key = keys.data_key(peer.domain_id, name, interface.type_name, interface.type_hash)
        self._inbox: Inbox[bytes] = Inbox(thread_name, depth, handle)
        self._subscriber = peer.session.declare_subscriber(
            key, lambda sample: self._inbox.put(sample.payload.to_bytes())
        )
        self._token = peer.session.liveliness().declare_token(self.token_key)

    def close(self) -> None:
        for entity in (self._token, self._subscriber):
            with contextlib.suppress(Exception):
                entity.undeclare()
        self._inbox.close()


class Request:
    """A query taken by a ``Server``: its CDR payload, answered once with ``reply``."""

    def __init__(self, query: zenoh.Query, key: str) -> None:
        self._query: zenoh.Query | None = query
        self._key = key
        self.sequence, self.client_gid = 0, bytes(keys.GID_SIZE)
        attachment = query.attachment
        if attachment is not None:
            with contextlib.suppress(struct.error):
                self.sequence, _stamp, self.client_gid = keys.unpack_attachment(
                    attachment.to_bytes()
                )
        payload = query.payload
        self.payload = payload.to_bytes() if payload is not None else b""

    def reply(self, payload: bytes) -> None:
        """Answer (once; later calls do nothing) and release the query: the caller's get ends."""
        query, self._query = self._query, None
        if query is None:
            return
        attachment = keys.pack_attachment(self.sequence, time.time_ns(), self.client_gid)
        try:
            query.reply(self._key, payload, attachment=attachment)
        finally:
            query.drop()

    def reply_error(self, text: str) -> None:
        """Answer with a zenoh error reply (the caller's call fails with ``text``), once."""
        query, self._query = self._query, None
        if query is None:
            return
        try:
            query.reply_err(text)
        finally:
            query.drop()


class Server:
    """A service ``name``: ``handle(request)`` runs on one thread and calls ``request.reply``.

    Every request is queued until it is handled (keep-all, as ROS services' queues are): a
    query released unanswered ends its caller's call with nothing to say why. ``depth`` is only
    what the token advertises. Requests still waiting when the server closes get an error
    reply that says so.
    """

    def __init__(
        self,
        peer: Peer,
        name: str,
        interface: ServiceInterface,
        handle: Callable[[Request], None],
        *,
        depth: int = 10,
        thread_name: str = "server",
    ) -> None:
        self.key = keys.data_key(peer.domain_id, name, interface.type_name, interface.type_hash)
        self.token_key = peer.entity_token(
            kind=keys.SERVICE,
            name=name,
            type_name=interface.type_name,
            type_hash=interface.type_hash,
            qos=keys.qos_chunk(depth=depth),
        )
        self._inbox: Inbox[Request] = Inbox(
            thread_name,
            None,
            handle,
            discard=lambda request: request.reply_error(
                "request dropped: the server is shutting down"
            ),
        )
        self._queryable = peer.session.declare_queryable(
            self.key, lambda query: self._inbox.put(Request(query, self.key)), complete=True
        )
        self._token = peer.session.liveliness().declare_token(self.token_key)

    @property
    def waiting(self) -> int:
        """Requests taken and not handled yet."""
        return self._inbox.waiting

    def close(self) -> None:
        for entity in (self._token, self._queryable):
            with contextlib.suppress(Exception):
                entity.undeclare()
        self._inbox.close()


# zenoh-python's (unstable) query cancellation came after 1.0, which pyconnect still takes:
# without it a cancelled call's query runs to its timeout, its reply dropped.
_HAS_CANCELLATION = hasattr(zenoh, "CancellationToken")


class CallCancel:
    """Ends the calls it is given to at once, from any thread: ``cancel()``."""

    def __init__(self) -> None:
        # Set before zenoh's token is cancelled: the token may end a query before it reports
        # is_cancelled, and the call must still know why its query ended.
        self._cancelled = threading.Event()
        self.token: Any = zenoh.CancellationToken() if _HAS_CANCELLATION else None

    @property
    def cancelled(self) -> bool:
        return self._cancelled.is_set()

    def cancel(self) -> None:
        self._cancelled.set()
        if self.token is not None:
            self.token.cancel()


class CallFailed(Exception):
    """A call got no response: the text says why (vanished, error, this peer's shutdown, or
    ``timed_out``)."""

    def __init__(self, text: str, *, timed_out: bool = False) -> None:
        super().__init__(text)
        self.timed_out = timed_out


class Caller:
    """A client of the service ``name``: ``call(payload, timeout)`` returns the response bytes."""

    def __init__(self, peer: Peer, name: str, interface: ServiceInterface) -> None:
        self._peer = peer
        self.name = name
        self.type_name = interface.type_name
        self.type_hash = interface.type_hash
        self.key = keys.data_key(peer.domain_id, name, interface.type_name, interface.type_hash)
        self.token_key = peer.entity_token(
            kind=keys.CLIENT,
            name=name,
            type_name=interface.type_name,
            type_hash=interface.type_hash,
            qos=keys.qos_chunk(),
        )
        self.gid = keys.gid_of(self.token_key)
        self._sequence = 0
        self._lock = threading.Lock()
        self._token = peer.session.liveliness().declare_token(self.token_key)

    @property
    def server_count(self) -> int:
        """Servers of this type and hash: a server of another one never sees the queries (its
        key differs)."""
        return self._peer.graph.count(
            kind=keys.SERVICE, name=self.name, type_name=self.type_name, type_hash=self.type_hash
        )

    def type_mismatch(self) -> str | None:
        """What is wrong when ``name`` has servers, but only of other types or hashes; None
        when a server of this type is there, or none at all."""
        others = self._peer.graph.other_types(
            kind=keys.SERVICE, name=self.name, type_name=self.type_name, type_hash=self.type_hash
        )
        if not others or self.server_count > 0:
            return None
        found = ", ".join(f"{name} ({type_hash})" for name, type_hash in others)
        return (
            f"the server of {self.name} has another type: expected {self.type_name} "
            f"({self.type_hash}), found {found}"
        )

    def call(
        self,
        payload: bytes,
        deadline: float | None,
        *,
        cancel: CallCancel | None = None,
    ) -> bytes:
        """The response's CDR bytes; ``CallFailed`` when none comes by ``deadline`` or
        ``cancel`` is cancelled (the query ends at once, its reply is never read)."""
        with self._lock:
            self._sequence += 1
            sequence = self._sequence
        attachment = keys.pack_attachment(sequence, time.time_ns(), self.gid)
        remaining = NO_TIMEOUT if deadline is None else max(0.001, deadline - time.monotonic())
        expiry = time.monotonic() + remaining  # zenoh's timer starts after this, never before
        token = None if cancel is None else cancel.token
        cancelling = {} if token is None else {"cancellation_token": token}
        try:
            replies: Any = self._peer.session.get(
                self.key,
                target=zenoh.QueryTarget.ALL_COMPLETE,
                consolidation=zenoh.ConsolidationMode.NONE,
                timeout=remaining,
                payload=payload,
                attachment=attachment,
                **cancelling,
            )
        except zenoh.ZError as error:  # "session closed": the peer shut down since the check
            if cancel is not None and cancel.cancelled:
                raise self._cancelled() from error
            if not self._peer.ok():
                raise self._shut_down() from error
            raise CallFailed(f"the call to {self.name} failed: {error}") from error
        errors: list[str] = []
        timed_out = False
        for reply in replies:
            if reply.ok is None:
                err = reply.err
                if _is_query_timeout(reply, expiry):
                    timed_out = True
                elif err is None:
                    errors.append("unknown error")
                else:
                    # Any server may send any bytes: to_string() raises on what is not UTF-8.
                    errors.append(err.payload.to_bytes().decode(errors="replace"))
                continue
            response: bytes = reply.ok.payload.to_bytes()
            return response
        if cancel is not None and cancel.cancelled:
            raise self._cancelled()
        if errors:
            raise CallFailed(f"the server of {self.name} failed: {'; '.join(errors)}")
        if timed_out:
            raise CallFailed(f"no response from {self.name} in time", timed_out=True)
        if not self._peer.ok():
            # Closing this peer's session ends its queries without a reply: no server's fault.
            raise self._shut_down()
        mismatch = self.type_mismatch()
        if mismatch is not None:
            raise CallFailed(mismatch)
        if self.server_count == 0:
            raise CallFailed(f"the server of {self.name} vanished before it replied")
        if deadline is not None and time.monotonic() >= deadline - 0.01:
            raise CallFailed(f"no response from {self.name} in time", timed_out=True)
        # zenoh ended the query early: the server's session went away (its token may be gone
        # from the graph a moment later).
        raise CallFailed(f"the server of {self.name} went away before it replied")

    def _shut_down(self) -> CallFailed:
        # The text an agent gives for any call made after its peer's shutdown (why_no_answer).
        return CallFailed(f"peer {self._peer.name!r} is shut down")

    def _cancelled(self) -> CallFailed:
        return CallFailed(f"the call to {self.name} was cancelled")

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self._token.undeclare()


def _is_query_timeout(reply: Any, expiry: float) -> bool:
    """Whether ``reply`` is zenoh's own end of a query at its timeout: an error reply saying
    "Timeout", sent by this session (no replier) or by the remote one that routed the query
    (it expires the query too, a moment after this one). A server's error reply, whatever its
    text, comes before the expiry: after it the query is over."""
    err = reply.err
    if err is None or err.payload.to_bytes() != ZENOH_TIMEOUT_REPLY:
        return False
    # replier_id is an unstable part of zenoh-python's Reply: read it where it is there.
    return getattr(reply, "replier_id", None) is None or time.monotonic() >= expiry
