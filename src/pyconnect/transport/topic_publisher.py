"""A peer's ``pub`` agent: values published on an rmw_zenoh topic as rmw_zenoh does.

The key names the topic and the type (with its RIHS01 hash), the payload is the value's CDR
(the wire codecs'), and the attachment carries rmw_zenoh's sequence number, source time stamp
and the publisher's GID (pyconnect.transport.rmw_zenoh_keys), from which subscribers count what
they lost (pyconnect.transport.topic_subscriber).
"""

# zenoh's stubs leave undeclare() and close() unannotated.
# mypy: disable-error-code="no-untyped-call"

from __future__ import annotations

import contextlib
import threading
import time
from typing import Any

import zenoh

from pyconnect.errors import TransportError
from pyconnect.ros.option_checks import depth_problem, period_problem
from pyconnect.transport import rmw_zenoh_keys as keys
from pyconnect.transport.async_handlers import agent_loop, cancel_coroutine, settle
from pyconnect.transport.conversion import DecodeFunc, EncodeFunc
from pyconnect.transport.interface_types import message_interface
from pyconnect.transport.peer_agent import DEFAULT_DEPTH, Peer, PeerAgent, ResponseFunc
from pyconnect.transport.periodic import run_every

_pack_attachment = keys.ATTACHMENT.pack  # bound once: no wrapper per sample
GID_SIZE = keys.GID_SIZE
time_ns = time.time_ns


class PublisherAgent(PeerAgent):
    """Publishes values of ``data_interface`` on ``conn_name`` as rmw_zenoh does."""

    conn_type = "pub"

    def __init__(
        self,
        peer: Peer,
        *,
        conn_name: str,
        agent_name: str | None = None,
        data_interface: object,
        encode_func: EncodeFunc | None = None,
        decode_func: DecodeFunc | None = None,
        response_func: ResponseFunc | None = None,
        time_period: float | None = None,
        only_if_subscribed: bool = False,
        depth: int = DEFAULT_DEPTH,
        raw: bool = False,
    ) -> None:
        interface = message_interface(data_interface)
        super().__init__(
            peer,
            conn_name=conn_name,
            agent_name=agent_name,
            type_name=interface.type_name,
            response_func=response_func,
        )
        del decode_func  # accepted for CustomNode's signature; a publisher decodes nothing
        if response_func is not None and time_period is None:
            raise self.error("response_func on a 'pub' agent needs time_period (it is polled)")
        problem = None if time_period is None else period_problem(time_period)
        if problem is not None:
            raise self.error(problem)
        # The depth goes into the liveliness token, which rmw_zenoh parses: refused here.
        problem = depth_problem(depth)
        if problem is not None:
            raise self.error(problem)
        self.conversion = self.wire_conversion(interface.codec, encode_func=encode_func, raw=raw)
        self.only_if_subscribed = only_if_subscribed
        self.time_period = time_period
        self.sent_count = 0
        self.key = keys.data_key(
            peer.domain_id, self.topic, interface.type_name, interface.type_hash
        )
        self.token_key = peer.entity_token(
            kind=keys.PUBLISHER,
            name=self.topic,
            type_name=interface.type_name,
            type_hash=interface.type_hash,
            qos=keys.qos_chunk(depth=depth),
        )
        self.gid = keys.gid_of(self.token_key)
        self._type_hash = interface.type_hash
        self._sequence = 0
        self._send_lock = threading.Lock()
        # rmw_zenoh (rmw_publisher_data.cpp): reliable keep-last publishers drop on congestion.
        self._publisher = peer.session.declare_publisher(
            self.key,
            congestion_control=zenoh.CongestionControl.DROP,
            reliability=zenoh.Reliability.RELIABLE,
        )
        self._put = self._publisher.put
        self._encode = self.conversion.encode
        self._token = peer.session.liveliness().declare_token(self.token_key)
        self._stop = threading.Event()
        self._timer: threading.Thread | None = None
        if time_period is not None:
            self._timer = threading.Thread(
                target=self._run_period, name=f"pyconnect-pub-{self.name}", daemon=True
            )
            self._timer.start()

    @property
    def subscriber_count(self) -> int:
        """How many subscriptions of this type and hash on this topic the graph shows now
        (one of another type is on another key: it never gets these samples)."""
        return self.peer.graph.count(
            kind=keys.SUBSCRIPTION,
            name=self.topic,
            type_name=self.type_name,
            type_hash=self._type_hash,
        )

    @property
    def matched(self) -> bool:
        """Whether zenoh routes this publisher's samples to any subscriber now (tokens or not)."""
        status: Any = self._publisher.matching_status  # a MatchingStatus (stubs say bool)
        return bool(getattr(status, "matching", status))

    def send(self, data: Any = None) -> bool:
        """Encode and publish ``data``; False when skipped (``only_if_subscribed``, no reader)."""
        if self.only_if_subscribed and self.subscriber_count == 0:
            return False
        payload = self._encode(data)
        stamp = time_ns()
        with self._send_lock:  # sequence numbers go on the wire in order
            self._sequence = sequence = self._sequence + 1
            try:
                attachment = _pack_attachment(sequence, stamp, GID_SIZE, self.gid)
                self._put(payload, attachment=attachment)
            except zenoh.ZError as error:  # zenoh's words ("Undeclared publisher") name no agent
                state = "is shut down" if self._stop.is_set() else f"failed: {error}"
                raise TransportError(f"{self.describe}: peer {self.peer.name!r} {state}") from error
            self.sent_count += 1  # under the lock: sends from several threads all count
        self._latest = data
        return True

    def _run_period(self) -> None:
        period = self.time_period or 1.0  # set whenever this thread runs
        with agent_loop():  # an ``async def`` response_func runs on this thread's loop
            run_every(period, self._stop, self._send_period)

    def _send_period(self) -> None:
        if self.only_if_subscribed and self.subscriber_count == 0:
            return
        try:
            func = self.response_func
            value = settle(func()) if func is not None else self._latest
            if value is not None:
                self.send(value)
        except Exception as error:
            self.report_exception("periodic send", error)
        except BaseException as error:  # sys.exit() in response_func: ended the thread unseen
            self.exit_requested("periodic send", error)

    def close(self) -> None:
        self._stop.set()
        if self._timer is not None and self._timer is not threading.current_thread():
            cancel_coroutine(self._timer)
            self._timer.join(5.0)
        for entity in (self._token, self._publisher):
            with contextlib.suppress(Exception):
                entity.undeclare()
