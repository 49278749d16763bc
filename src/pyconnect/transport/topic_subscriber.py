"""A peer's ``sub`` agent: samples of an rmw_zenoh topic checked, decoded and handed on in order.

A subscriber listens on its own type's key. Publishers of another type (or of another version
of the type: a different RIHS01 hash) show up in the graph with their tokens; for each such
key the agent also listens there, so their samples are seen instead of silently missed: they
are not decoded, they are counted in ``type_mismatch_count`` and reported once per publisher
with both type names (pyconnect.transport.other_type_keys: while a publisher token names the
key, on a bounded number of keys). (A publisher that declares no token, e.g. a bare zenoh
session, is not seen on another type's key.) Payloads over the peer's ``max_payload_bytes`` are
dropped and counted (``oversize_count``), also reported once per publisher. Payloads are CDR,
decoded by the wire codecs; nothing is ever unpickled.

The per-sample path is short (bench/transport.py and bench/transport_stages.py measure it).
zenoh's own thread pushes each sample into a ``zenoh.handlers.RingChannel``, in Rust: no GIL,
no Python frame, never blocking the link. The agent's one thread blocks in ``recv()`` (the GIL
released), takes everything else waiting with ``try_recv()`` (one wake-up per burst), and
checks, decodes and hands each sample to ``response_func`` in arrival order, so user code never
blocks zenoh (an ``async def`` one runs to completion there: pyconnect.transport.async_handlers).
Keep-last: zenoh delivers samples in bursts (one transport batch holds up to
~1000 small samples, all pushed at once), so a ring of exactly ``depth`` would drop most of a
burst even from an agent that keeps up on average; for types without unbounded sequences
(``burst_samples``: String, Twist, poses...) the ring and the agent hold up to 1000 samples
beyond ``depth`` while the agent keeps up, i.e. found nothing waiting within the last
``burst_seconds`` (20 ms). An agent busy longer (a slow ``response_func``) skips to the newest
``depth`` samples, as ROS keep-last does; types with arrays (Image, PointCloud2, JointState...)
keep exactly ``depth`` (a few large samples, never a thousand). rmw_zenoh's subscription queue
(``rmw_subscription_data.cpp``, ``SubscriptionData::add_new_message``) keeps ``depth`` and drops
the oldest, bursts included. Samples lost on the way (skipped by keep-last, or dropped by
zenoh's congestion control) are counted in ``dropped_count`` from the publishers' sequence gaps
(samples without an attachment, from a bare zenoh session, are counted when the agent skips
them; what zenoh's ring drops of them leaves no trace). Samples skipped before the first one
of their publisher the agent handles count too: the first skipped one starts the count. A
sequence number that goes backwards or jumps by more than ``MAX_SEQUENCE_GAP`` is a restarted
publisher or a bogus number: counting restarts from it, no gap counted. An attachment that is
not rmw_zenoh's 33 bytes is counted in ``bad_attachment_count`` and reported once; its sample
is still decoded and handed on.
"""

# zenoh's stubs leave undeclare() and close() unannotated.
# mypy: disable-error-code="no-untyped-call"

from __future__ import annotations

import collections
import contextlib
import struct
import threading
import time
from typing import Any

import zenoh

from pyconnect.codecs.wire import WireCodec
from pyconnect.errors import DecodeError
from pyconnect.ros.option_checks import call_timeout, depth_problem
from pyconnect.transport import rmw_zenoh_keys as keys
from pyconnect.transport.async_handlers import agent_loop, cancel_coroutine, settle
from pyconnect.transport.conversion import DecodeFunc, EncodeFunc
from pyconnect.transport.interface_types import message_interface
from pyconnect.transport.other_type_keys import OtherTypeKeys
from pyconnect.transport.peer_agent import DEFAULT_DEPTH, Peer, PeerAgent, ResponseFunc, logger

# What an agent that keeps up on average may hold beyond ``depth`` while it works through a burst.
BURST_SAMPLES = 1000
BURST_SECONDS = 0.02
# The most samples one gap in a publisher's sequence numbers may stand for: a longer jump (or
# one backwards) is a restarted publisher or a bogus number, not ~2**62 lost samples.
MAX_SEQUENCE_GAP = 2**20
# (sequence, stamp ns, GID length, GID); struct.error if malformed
_unpack_attachment = keys.ATTACHMENT.unpack
GID_SIZE = keys.GID_SIZE
time_ns = time.time_ns
monotonic = time.monotonic


def has_small_messages(codec: WireCodec) -> bool:
    """Whether ``codec``'s type has no unbounded sequence, nested types included (strings may
    be long, but such types are commands, poses, counters: small in practice)."""
    rows = codec.definitions
    seen: set[str] = set()
    pending = [codec.msg_type]
    while pending:
        type_name = pending.pop()
        if type_name in seen or type_name not in rows:
            continue
        seen.add(type_name)
        for _name, kind, element, _bound, container, *_rest in rows[type_name][1]:
            if container == "sequence":
                return False
            if kind == "message":
                pending.append(element)
    return True


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
        self.conversion = self.wire_conversion(interface.codec, decode_func=decode_func, raw=raw)
        problem = depth_problem(depth)
        if problem is not None:
            raise self.error(problem)
        self.type_hash = interface.type_hash
        self.depth = depth
        self.message_count = 0
        self.type_mismatch_count = 0
        self.oversize_count = 0
        self.last_received_ns = 0
        self.bad_attachment_count = 0
        """Samples whose attachment is not rmw_zenoh's (decoded and handed on all the same)."""
        self._reported: set[tuple[str, str]] = set()
        self._first_message = threading.Event()
        self._last_sequence: dict[bytes, int] = {}
        self._interrupted: dict[bytes, int] = {}
        """Per publisher, its sequence number before an implausible jump (see _sequence_jump)."""
        self.dropped_count = 0
        """Samples lost before this agent handled them: gaps in each publisher's sequence
        numbers (zenoh dropped them on congestion, or this agent skipped them to keep up)."""
        self.token_key = peer.entity_token(
            kind=keys.SUBSCRIPTION,
            name=self.topic,
            type_name=interface.type_name,
            type_hash=interface.type_hash,
            qos=keys.qos_chunk(depth=depth),
        )
        self.key = keys.data_key(peer.domain_id, self.topic, interface.type_name, self.type_hash)
        self._decode = self.conversion.decode
        self.burst_samples = BURST_SAMPLES if has_small_messages(interface.codec) else 0
        """How many samples beyond ``depth`` zenoh's ring and the agent hold while the agent
        works through a burst (types without unbounded sequences; 0 for the others)."""
        self.burst_seconds = BURST_SECONDS
        """Samples beyond ``depth`` are kept only while the agent found nothing waiting this
        recently: once it has been busy longer (a slow ``response_func``), keep-last applies."""
        self._subscriber = peer.session.declare_subscriber(
            self.key, zenoh.handlers.RingChannel(depth + self.burst_samples)
        )
        self._token = peer.session.liveliness().declare_token(self.token_key)
        self._other_types = OtherTypeKeys(
            peer.session,
            domain_id=peer.domain_id,
            topic=self.topic,
            own_key=self.key,
            type_name=self.type_name,
            type_hash=self.type_hash,
            describe=self.describe,
            thread_name=f"pyconnect-sub-{self.name}-types",
            on_sample=self._on_other_type,
        )
        self._closed = False
        self._thread = threading.Thread(
            target=self._run, name=f"pyconnect-sub-{self.name}", daemon=True
        )
        self._thread.start()
        peer.graph.watch(self._other_types.on_token, gone=self._other_types.on_token_gone)

    # -- publishers of other types ---------------------------------------------------------------
    def _on_other_type(self, sample: zenoh.Sample, text: str) -> None:
        """A sample on the key of a publisher of another type (zenoh's thread): not decoded."""
        self.type_mismatch_count += 1
        self._report_once("type", sample.attachment, text)

    # -- the agent's thread ----------------------------------------------------------------------
    def _run(self) -> None:
        with agent_loop():  # an ``async def`` response_func runs on this thread's loop
            self._handle_samples()

    def _handle_samples(self) -> None:
        samples: Any = self._subscriber.handler  # a zenoh Handler[Sample] (stubs: generic)
        recv, try_recv, handle = samples.recv, samples.try_recv, self._on_sample
        depth, most = self.depth, self.depth + self.burst_samples
        backlog: collections.deque[zenoh.Sample] = collections.deque()
        take, append = backlog.popleft, backlog.append
        idle_at = monotonic()
        while True:
            try:
                sample = try_recv()
                if sample is None:  # zenoh's ring is empty: the agent keeps up
                    idle_at = monotonic()
                    sample = recv()  # waits with the GIL released
                while sample is not None:  # take the whole burst: one wake-up per burst
                    append(sample)
                    if len(backlog) > most:  # a whole ring's worth: handle it (keep-last) first
                        break
                    sample = try_recv()
                self.last_received_ns = time_ns()
            except zenoh.ZError:
                return  # the subscriber is undeclared: the agent is closing
            while backlog and not self._closed:  # closing: what waits is not handed on
                if len(backlog) > depth and (
                    len(backlog) > most or monotonic() - idle_at > self.burst_seconds
                ):
                    self._keep_last(backlog)
                try:
                    handle(take())
                except Exception as error:
                    self.report_exception("receive", error)
                except BaseException as error:  # sys.exit() in response_func
                    self.exit_requested("receive", error)

    def _keep_last(self, backlog: collections.deque[zenoh.Sample]) -> None:
        """Skip all but the newest ``depth`` waiting samples (the agent fell behind).

        Skipped samples are counted in ``dropped_count`` through the sequence gap the next
        handled sample shows, or here when they carry no readable attachment. A publisher not
        heard from yet gets the sequence number before its first skipped sample as its last
        one, so the next handled sample shows the gap (the first handled sample of a publisher
        is otherwise taken as its start).
        """
        last_sequence = self._last_sequence
        while len(backlog) > self.depth:
            attachment = backlog.popleft().attachment
            if attachment is None:
                self.dropped_count += 1
                continue
            try:
                sequence, _stamp, gid_size, gid = _unpack_attachment(attachment.to_bytes())
            except struct.error:
                gid_size = 0
            if gid_size != GID_SIZE:
                self.dropped_count += 1  # no sequence to count it from later
            elif gid not in last_sequence:
                last_sequence[gid] = sequence - 1

    def _on_sample(self, sample: zenoh.Sample) -> None:
        attachment = sample.attachment
        if attachment is not None:
            try:
                sequence, _stamp, gid_size, gid = _unpack_attachment(attachment.to_bytes())
            except struct.error:
                gid_size = 0
            if gid_size != GID_SIZE:
                self._bad_attachment(attachment)
            else:
                last = self._last_sequence.get(gid, sequence - 1)
                if sequence != last + 1:  # rare: a gap, a restart or a bogus number
                    self._sequence_jump(gid, last, sequence)
                self._last_sequence[gid] = sequence
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
        try:
            value = self._decode(payload.to_bytes())
        except Exception as error:
            if not isinstance(error, DecodeError):
                error = DecodeError(f"{type(error).__name__}: {error}")
            self.report_exception("decode", error)
            return
        self._latest = value
        self.message_count = count = self.message_count + 1
        if count == 1:
            self._first_message.set()
        response_func = self.response_func
        if response_func is not None:
            try:
                outcome = response_func(value)
                if outcome is not None:  # a plain handler's None skips the coroutine check
                    settle(outcome)
            except Exception as error:
                self.report_exception("response_func", error)

    def _sequence_jump(self, gid: bytes, last: int, sequence: int) -> None:
        """Count the samples lost before ``sequence`` when its jump from ``last`` is a gap.

        A sequence number that goes backwards or jumps further than ``MAX_SEQUENCE_GAP`` is a
        restarted publisher or a bogus number: counting restarts from it, and where the run
        stood before is kept, so a later sample that continues that run (the odd number was a
        one-off) is counted from there, not as a gap from the odd one.
        """
        before = self._interrupted.get(gid)
        base = last if 0 < sequence - last <= MAX_SEQUENCE_GAP + 1 else None
        if before is not None and 0 < sequence - before <= MAX_SEQUENCE_GAP + 1:
            base = before if base is None else max(base, before)
        if base is None:
            if before is None:
                self._interrupted[gid] = last
            return
        self.dropped_count += sequence - base - 1
        if before is not None and sequence > before:
            del self._interrupted[gid]  # the run before the jump is over (or resumed here)

    def _bad_attachment(self, attachment: zenoh.ZBytes) -> None:
        self.bad_attachment_count += 1
        self._report_once(
            "attachment",
            attachment,
            f"attachment of {len(attachment)} bytes, expected {keys.ATTACHMENT_SIZE} "
            "(rmw_zenoh's sequence number, source timestamp and GID); its samples are handed "
            "on, not checked for gaps",
        )

    def _report_once(self, what: str, attachment: zenoh.ZBytes | None, text: str) -> None:
        publisher = "without attachment"
        if attachment is not None:
            try:
                publisher = keys.unpack_attachment(attachment.to_bytes())[2].hex()
            except struct.error:
                # Nothing tells such publishers apart: reported once for all of them.
                publisher = "with an unreadable attachment"
        if (what, publisher) in self._reported:
            return
        self._reported.add((what, publisher))
        logger.warning("%s on %s: publisher %s: %s", self.describe, self.topic, publisher, text)

    def wait_for_message(self, timeout: float | None = None) -> bool:
        wait = call_timeout(timeout, None, where=f"{self.describe}: wait_for_message")
        return self._first_message.wait(wait)

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
        self._closed = True
        self.peer.graph.unwatch(self._other_types.on_token)
        for entity in (self._token, self._subscriber):
            with contextlib.suppress(Exception):
                entity.undeclare()  # the subscriber's: its channel closes, recv() ends the thread
        self._other_types.close(5.0)
        if self._thread is not threading.current_thread():
            cancel_coroutine(self._thread)
            self._thread.join(5.0)
