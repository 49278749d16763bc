"""One read of a bag's storage files: their messages merged in log-time order, each decoded.

``ConnectionDecoders`` gives each connection its decoder (one per type, definition and type
hash, kept across reads); ``MergedRead`` plans one pass over the files (a topic, type and
decoder per connection read) and yields their messages as ``BagMessage``s, the undecodable ones
noted in the read's ``ProblemLog`` (``pyconnect.record.bag_read_report``) instead.
"""

from __future__ import annotations

import heapq
import logging
from collections.abc import Container, Iterator, Mapping, Sequence
from collections.abc import Set as AbstractSet
from operator import itemgetter
from pathlib import Path
from typing import Any

from pyconnect.record.bag_info import TopicInfo
from pyconnect.record.bag_message import BagMessage, message_maker
from pyconnect.record.bag_read_report import ProblemLog
from pyconnect.record.bag_storage import Connection, RawMessage, StorageFile
from pyconnect.record.topic_decoder import (
    TopicDecoder,
    TypeMismatch,
    normalise_type_name,
    type_mismatch,
)
from pyconnect.record.topic_selection import reads_connection

__all__ = ["ConnectionDecoders", "MergedRead"]

_log = logging.getLogger("pyconnect.record")


class ConnectionDecoders:
    """The decoder of each connection of a bag, built once per type, definition and type hash.

    A type hash that differs from the installed type's is listed in ``mismatches`` and logged;
    the installed type then never decodes that connection.
    """

    def __init__(
        self, path: Path, topics: Mapping[str, TopicInfo], *, natural: bool, registry: Any
    ) -> None:
        self.path = path
        self.topics = topics
        self.natural = natural
        self.registry = registry
        self.mismatches: list[TypeMismatch] = []
        self._decoders: dict[tuple[str, str | None, str, str], TopicDecoder] = {}

    def decoder(self, connection: Connection) -> TopicDecoder:
        key = (
            connection.msg_type,
            connection.definition,
            connection.definition_encoding,
            connection.type_hash,
        )
        decoder = self._decoders.get(key)
        if decoder is None:
            mismatch = self._check_hash(connection)
            decoder = TopicDecoder(
                connection.msg_type,
                connection.definition,
                connection.definition_encoding,
                natural=self.natural,
                registry=self.registry,
                installed_allowed=mismatch is None,
                # The file's hash, else the one metadata.yaml gives for the topic.
                type_hash=connection.type_hash or self.topics[connection.topic].type_hash,
            )
            self._decoders[key] = decoder
        return decoder

    def _check_hash(self, connection: Connection) -> TypeMismatch | None:
        mismatch = type_mismatch(connection)
        if mismatch is not None:
            self.mismatches.append(mismatch)
            _log.warning("%s: %s", self.path, mismatch)
        return mismatch


class _Plan:
    """How one connection of one storage file is read: its topic, type, decoder and messages."""

    __slots__ = ("decoder", "make", "msg_type", "topic")

    def __init__(self, topic: str, msg_type: str, decoder: TopicDecoder | None) -> None:
        self.topic = topic
        self.msg_type = msg_type
        self.decoder = decoder
        self.make = message_maker(msg_type)


def _keyed(number: int, stream: Iterator[RawMessage]) -> Iterator[tuple[Any, int, Any]]:
    """A file's messages keyed by (file number, connection id), for merging several files."""
    for connection_id, log_time, data in stream:
        yield (number, connection_id), log_time, data


class MergedRead:
    """One pass over the ``topics`` of ``storages`` from ``start_ns`` to ``end_ns`` (exclusive);
    ``decoders`` None reads the CDR bytes undecoded. ``delivered`` counts what it yielded.

    ``types`` (normalised type names; None: any) leaves out the connections of other types
    (``pyconnect.record.topic_selection.reads_connection``). ``codec`` is the wire codec the
    message last yielded was decoded with (None before the first, and when reading undecoded):
    per connection, as a topic's connections may store different definitions."""

    def __init__(
        self,
        storages: Sequence[StorageFile],
        topics: Container[str],
        decoders: ConnectionDecoders | None,
        start_ns: int | None,
        end_ns: int | None,
        *,
        types: AbstractSet[str] | None = None,
    ) -> None:
        self.delivered = 0
        self.codec: Any = None
        # One plan per connection of each file, keyed by the connection id (one file) or by
        # (file number, id) when several files are merged by log time.
        self._plans: dict[Any, _Plan] = {}
        self._streams: list[Iterator[RawMessage]] = []
        self._raw = decoders is None
        for number, storage in enumerate(storages):
            ids = set()
            for connection in storage.connections():
                if reads_connection(connection, topics, types):
                    msg_type = normalise_type_name(connection.msg_type)
                    decoder = None if decoders is None else decoders.decoder(connection)
                    key = connection.id if len(storages) == 1 else (number, connection.id)
                    self._plans[key] = _Plan(connection.topic, msg_type, decoder)
                    ids.add(connection.id)
            self._streams.append(storage.messages(ids, start_ns, end_ns))

    def messages(self, problems: ProblemLog, switched: dict[str, int]) -> Iterator[BagMessage]:
        """The messages; ``switched`` gets each topic whose decoder gave up the definition stored
        in the bag, with how many of its messages had been delivered decoded with it."""
        streams, plans = self._streams, self._plans
        if len(streams) == 1:
            merged: Iterator[tuple[Any, int, Any]] = streams[0]
        else:
            merged = heapq.merge(
                *(_keyed(number, stream) for number, stream in enumerate(streams)),
                key=itemgetter(1),
            )
        delivered = 0
        try:
            if self._raw:
                for key, log_time, data in merged:
                    delivered += 1
                    plan = plans[key]
                    yield plan.make((plan.topic, log_time, bytes(data)))
                return
            counts: dict[str, int] = {}
            failed: dict[str, int] = {}  # per topic, counted here: errors are many at times
            for key, log_time, data in merged:
                delivered += 1
                plan = plans[key]
                topic = plan.topic
                index = counts.get(topic, 0)
                counts[topic] = index + 1
                decoder = plan.decoder
                assert decoder is not None
                try:
                    value = decoder.decode(data)
                except Exception as error:  # any codec failure is one message's problem
                    before = index - failed.get(topic, 0)
                    try:
                        value = decoder.recover(data, error, topic=topic)
                    except Exception as final:
                        failed[topic] = failed.get(topic, 0) + 1
                        problems.add(topic, index, log_time, final)
                        continue
                    # recover() returned a value: the decoder has just given up the stored
                    # definition.
                    if before > 0:
                        switched.setdefault(topic, before)
                # After decoding: recover() has just switched the decoder's codec.
                self.codec = decoder.codec
                yield plan.make((topic, log_time, value))
        finally:
            self.delivered = delivered
            for stream in streams:
                stream.close()  # type: ignore[attr-defined]  # generators: before the files
