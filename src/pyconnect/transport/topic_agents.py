"""A peer's ``pub`` and ``sub`` agents: rmw_zenoh topics (key, CDR payload, attachment, token).

The subscriber listens on ``<domain>/<topic>/*/*`` rather than on its own type's key alone, so
that a publisher of another type (or another version of the type: a different RIHS01 hash) is
seen instead of silently missed: its samples are not decoded, they are counted in
``type_mismatch_count`` and reported once per publisher with both type names. Payloads over
the peer's ``max_payload_bytes`` are dropped and counted (``oversize_count``), also reported
once per publisher. Payloads are CDR, decoded by the wire codecs; nothing is ever unpickled.
"""

# zenoh's stubs leave undeclare() and close() unannotated.
# mypy: disable-error-code="no-untyped-call"

from __future__ import annotations

import contextlib
import struct
import threading
import time
from typing import Any

import zenoh

from pyconnect.errors import DecodeError
from pyconnect.transport import rmw_zenoh_keys as keys
from pyconnect.transport.conversion import DecodeFunc, EncodeFunc, WireConversion
from pyconnect.transport.interface_types import message_interface
from pyconnect.transport.peer_agent import Peer, PeerAgent, ResponseFunc, logger

DEFAULT_DEPTH = 10


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
        if time_period is not None and time_period <= 0:
            raise self.error(f"time_period must be > 0 seconds, got {time_period!r}")
        self.conversion = WireConversion(
            describe=self.describe,
            codec=interface.codec,
            registry=peer.registry,
            encode_func=encode_func,
            raw=raw,
        )
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
        self._sequence = 0
        self._send_lock = threading.Lock()
        # rmw_zenoh (rmw_publisher_data.cpp): reliable keep-last publishers drop on congestion.
        self._publisher = peer.session.declare_publisher(
            self.key,
            congestion_control=zenoh.CongestionControl.DROP,
            reliability=zenoh.Reliability.RELIABLE,
        )
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
        """How many subscriptions on this topic the graph shows now."""
        return self.peer.graph.count(kind=keys.SUBSCRIPTION, name=self.topic)

    @property
    def matched(self) -> bool:
        """Whether zenoh routes this publisher's samples to any subscriber now (tokens or not)."""
        status: Any = self._publisher.matching_status  # a MatchingStatus (stubs say bool)
        return bool(getattr(status, "matching", status))

    def send(self, data: Any = None) -> bool:
        """Encode and publish ``data``; False when skipped (``only_if_subscribed``, no reader)."""
        if self.only_if_subscribed and self.subscriber_count == 0:
            return False
        payload = self.conversion.encode(data)
        with self._send_lock:
            self._sequence += 1
            attachment = keys.pack_attachment(self._sequence, time.time_ns(), self.gid)
            self._publisher.put(payload, attachment=attachment)
        self._latest = data
        self.sent_count += 1
        return True

    def _run_period(self) -> None:
        period = self.time_period or 1.0  # set whenever this thread runs
        while not self._stop.wait(period):
            if self.only_if_subscribed and self.subscriber_count == 0:
                continue
            try:
                value = self.response_func() if self.response_func is not None else self._latest
                if value is not None:
                    self.send(value)
            except Exception as error:
                self.report_exception("periodic send", error)

    def close(self) -> None:
        self._stop.set()
        if self._timer is not None and self._timer is not threading.current_thread():
            self._timer.join(5.0)
        for entity in (self._token, self._publisher):
            with contextlib.suppress(Exception):
                entity.undeclare()


class SubscriberAgent(PeerAgent):
    """Receives ``conn_name``; every sample is checked, decoded, kept and passed on."""

    conn_type = "sub"

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
        del encode_func  # accepted for CustomNode's signature; a subscriber encodes nothing
        self.conversion = WireConversion(
            describe=self.describe,
            codec=interface.codec,
            registry=peer.registry,
            decode_func=decode_func,
            raw=raw,
        )
        self.type_hash = interface.type_hash
        self.message_count = 0
        self.type_mismatch_count = 0
        self.oversize_count = 0
        self.last_received_ns = 0
        self._dds_name = keys.dds_type_name(interface.type_name)
        self._verdicts: dict[str, str | None] = {}
        self._reported: set[tuple[str, bytes]] = set()
        self._first_message = threading.Event()
        self._last_sequence: dict[bytes, int] = {}
        self.dropped_count = 0
        """Samples lost before this agent saw them: gaps in each publisher's sequence numbers
        (zenoh's ring of ``depth`` samples keeps the newest when the agent falls behind)."""
        self.token_key = peer.entity_token(
            kind=keys.SUBSCRIPTION,
            name=self.topic,
            type_name=interface.type_name,
            type_hash=interface.type_hash,
            qos=keys.qos_chunk(depth=depth),
        )
        # Samples wait in zenoh's own ring (no Python on zenoh's threads, no lock per sample);
        # this agent's thread takes them, so user code never blocks zenoh.
        self._subscriber = peer.session.declare_subscriber(
            keys.data_key_any_type(peer.domain_id, self.topic), zenoh.handlers.FifoChannel(depth)
        )
        self._token = peer.session.liveliness().declare_token(self.token_key)
        self._thread = threading.Thread(
            target=self._run, name=f"pyconnect-sub-{self.name}", daemon=True
        )
        self._thread.start()

    def _run(self) -> None:
        for sample in self._subscriber:
            try:
                self._on_sample(sample)
            except Exception as error:
                self.report_exception("receive", error)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        verdict = self._verdicts.get(key, "")
        if verdict == "":
            verdict = self._verdicts[key] = self._type_problem(key)
        attachment = sample.attachment
        if verdict is not None:
            self.type_mismatch_count += 1
            self._report_once("type", attachment, verdict)
            return
        if attachment is not None:
            self._count_gap(attachment)
        payload = sample.payload
        limit = self.peer.max_payload_bytes
        if limit is not None and len(payload) > limit:
            self.oversize_count += 1
            self._report_once(
                "size",
                attachment,
                f"dropped a {len(payload)}-byte sample (max_payload_bytes={limit})",
            )
            return
        self._on_payload(payload.to_bytes())

    def _count_gap(self, attachment: zenoh.ZBytes) -> None:
        try:
            sequence, _stamp, gid = keys.unpack_attachment(attachment.to_bytes())
        except struct.error:
            return
        last = self._last_sequence.get(gid)
        if last is not None and sequence > last + 1:
            self.dropped_count += sequence - last - 1
        self._last_sequence[gid] = sequence

    def _type_problem(self, key: str) -> str | None:
        chunks = key.rsplit("/", 2)
        if len(chunks) == 3 and chunks[1] == self._dds_name and chunks[2] == self.type_hash:
            return None
        other_type = keys.ros_type_name(chunks[1]) if len(chunks) == 3 else "?"
        other_hash = chunks[2] if len(chunks) == 3 else "?"
        return (
            f"ignored samples of {other_type} ({other_hash}); this subscription expects "
            f"{self.type_name} ({self.type_hash})"
        )

    def _report_once(self, what: str, attachment: zenoh.ZBytes | None, text: str) -> None:
        gid = b""
        if attachment is not None:
            try:
                gid = keys.unpack_attachment(attachment.to_bytes())[2]
            except struct.error:
                gid = b""
        if (what, gid) in self._reported:
            return
        self._reported.add((what, gid))
        publisher = gid.hex() if gid else "without attachment"
        logger.warning("%s on %s: publisher %s: %s", self.describe, self.topic, publisher, text)

    # -- the agent's thread --------------------------------------------------------------------
    def _on_payload(self, payload: bytes) -> None:
        try:
            value = self.conversion.decode(payload)
        except Exception as error:
            if not isinstance(error, DecodeError):
                error = DecodeError(f"{type(error).__name__}: {error}")
            self.report_exception("decode", error)
            return
        self._latest = value
        self.message_count += 1
        self.last_received_ns = time.time_ns()
        if not self._first_message.is_set():
            self._first_message.set()
        if self.response_func is not None:
            try:
                self.response_func(value)
            except Exception as error:
                self.report_exception("response_func", error)

    def wait_for_message(self, timeout: float | None = None) -> bool:
        return self._first_message.wait(timeout)

    @property
    def publisher_count(self) -> int:
        return self.peer.graph.count(kind=keys.PUBLISHER, name=self.topic)

    def is_connected(self) -> bool:
        return self.message_count > 0 and self.publisher_count > 0

    def waiting_for(self) -> str:
        if self.publisher_count == 0:
            return "no publisher now"
        return "no message yet"

    def close(self) -> None:
        for entity in (self._token, self._subscriber):
            with contextlib.suppress(Exception):
                entity.undeclare()
        if self._thread is not threading.current_thread():
            self._thread.join(5.0)
