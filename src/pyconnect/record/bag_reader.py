"""Read rosbag2 bags offline (no ROS graph, no rclpy): ``open_bag`` and ``bag_info``.

``open_bag(path)`` takes a bag directory (with or without metadata.yaml, one or several split
files), or one ``.mcap``/``.db3`` file, and yields one ``BagMessage`` per stored message, in
log-time order within each file (split files in order). A ``BagMessage`` has ``.topic``,
``.log_time_ns``, ``.msg_type`` and ``.value``, and unpacks as ``topic, log_time_ns, value``::

    with open_bag("run1", topics=["/odom"]) as bag:
        for topic, stamp_ns, value in bag:
            ...
        print(bag.errors)   # messages that could not be decoded

Values come from the wire codecs (``pyconnect.codecs.wire``): natural values by default, the
lossless dict with ``natural=False`` (the codec registry is asked once per topic, when its first
message is read, so a codec registered later applies to the next read). Each topic is decoded
with the definition stored in the bag when there is one (so a Foxy ``sensor_msgs/Range``
without ``variance`` decodes), else with the installed type; a stored definition that does not
fit the bytes gives way to the installed type. A message that cannot be decoded is skipped and
recorded in ``reader.errors`` (topic, index within the topic, reason; a summary goes to the
``pyconnect.record`` logger) and the read goes on; ``on_error="raise"`` raises ``DecodeError``
instead. Only CDR-serialised topics can be read: selecting another (``wrong_format``) raises
``BagError`` when the bag is opened.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from pyconnect.errors import DecodeError
from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_files import BagFiles, locate_bag_files, open_storage
from pyconnect.record.bag_storage import Connection, StorageFile
from pyconnect.record.topic_decoder import TopicDecoder, normalise_type_name, one_line

__all__ = [
    "BagInfo",
    "BagMessage",
    "BagReader",
    "DecodeProblem",
    "TopicInfo",
    "bag_info",
    "normalise_type_name",
    "open_bag",
]

_log = logging.getLogger("pyconnect.record")
OnError = Literal["report", "raise"]
Decoder = Callable[[Any], Any]


class BagMessage:
    """One decoded message; unpacks as ``(topic, log_time_ns, value)``."""

    __slots__ = ("log_time_ns", "msg_type", "topic", "value")

    def __init__(self, topic: str, log_time_ns: int, value: Any, msg_type: str) -> None:
        self.topic = topic
        self.log_time_ns = log_time_ns
        self.value = value
        self.msg_type = msg_type

    def __iter__(self) -> Iterator[Any]:
        return iter((self.topic, self.log_time_ns, self.value))

    def __repr__(self) -> str:
        return (
            f"BagMessage(topic={self.topic!r}, log_time_ns={self.log_time_ns}, "
            f"msg_type={self.msg_type!r}, value={self.value!r})"
        )


@dataclass(frozen=True)
class DecodeProblem:
    """A message that could not be decoded: ``index`` counts the topic's messages read, from 0."""

    topic: str
    index: int
    log_time_ns: int
    reason: str

    def __str__(self) -> str:
        return f"{self.topic}[{self.index}]: {self.reason}"


@dataclass(frozen=True)
class TopicInfo:
    """A topic of a bag: its type, how it is serialised and how many messages it has."""

    name: str
    msg_type: str
    message_count: int
    serialization_format: str = "cdr"
    has_definition: bool = False


@dataclass(frozen=True)
class BagInfo:
    """What ``pyconnect bag info`` prints. Times are ns since the epoch (None: no messages)."""

    path: Path
    storage: str
    files: tuple[Path, ...]
    topics: tuple[TopicInfo, ...]
    start_ns: int | None
    end_ns: int | None

    @property
    def message_count(self) -> int:
        return sum(topic.message_count for topic in self.topics)

    @property
    def duration_ns(self) -> int:
        if self.start_ns is None or self.end_ns is None:
            return 0
        return self.end_ns - self.start_ns


def _storage_name(files: Iterable[StorageFile]) -> str:
    kinds = {type(f).__name__ for f in files}
    names = {"McapFile": "mcap", "SqliteFile": "sqlite3"}
    return "+".join(sorted(names.get(kind, kind) for kind in kinds)) or "none"


@dataclass
class _TopicTally:
    msg_type: str
    serialization_format: str
    count: int = 0
    has_definition: bool = False


def _describe(located: BagFiles, storages: list[StorageFile]) -> BagInfo:
    """Counts and times from the storage files; metadata.yaml only adds what they lack."""
    metadata = located.metadata
    declared = {t.name: t for t in metadata.topics} if metadata is not None else {}
    tallies: dict[str, _TopicTally] = {}
    for storage in storages:
        counts = storage.message_counts()
        for connection in storage.connections():
            tally = tallies.setdefault(
                connection.topic,
                _TopicTally(connection.msg_type, connection.serialization_format),
            )
            tally.count += counts.get(connection.id, 0)
            tally.has_definition |= connection.definition is not None
            tally.msg_type = tally.msg_type or connection.msg_type
    for name, tally in tallies.items():
        topic_metadata = declared.get(name)
        if topic_metadata is None:
            continue
        tally.msg_type = tally.msg_type or topic_metadata.msg_type
        if topic_metadata.serialization_format not in ("", "cdr"):
            tally.serialization_format = topic_metadata.serialization_format
    ranges = [r for r in (s.time_range() for s in storages) if r is not None]
    return BagInfo(
        path=located.path,
        storage=_storage_name(storages),
        files=located.files,
        topics=tuple(
            TopicInfo(
                name=name,
                msg_type=tally.msg_type,
                message_count=tally.count,
                serialization_format=tally.serialization_format,
                has_definition=tally.has_definition,
            )
            for name, tally in sorted(tallies.items())
        ),
        start_ns=min(r[0] for r in ranges) if ranges else None,
        end_ns=max(r[1] for r in ranges) if ranges else None,
    )


class BagReader:
    """An open bag: iterate it for ``BagMessage``s; ``info`` describes it; close when done.

    See the module docstring for the options; ``open_bag`` is the usual way to make one.
    """

    def __init__(
        self,
        path: str | Path,
        *,
        topics: Iterable[str] | None = None,
        start_ns: int | None = None,
        end_ns: int | None = None,
        natural: bool = True,
        on_error: OnError = "report",
    ) -> None:
        if on_error not in ("report", "raise"):
            raise ValueError(f"on_error: expected 'report' or 'raise', got {on_error!r}")
        self.on_error: OnError = on_error
        self.natural = natural
        self.start_ns = start_ns
        self.end_ns = end_ns
        self.errors: list[DecodeProblem] = []
        self._located: BagFiles = locate_bag_files(path)
        self.path = self._located.path
        self._storages: list[StorageFile] = []
        try:
            self._storages = [open_storage(p) for p in self._located.files]
            self.info = _describe(self._located, self._storages)
            self.topics = self._select(topics)
        except BaseException:
            self.close()
            raise
        self._decoders: dict[tuple[str, str | None, str], TopicDecoder] = {}
        self._counts: dict[str, int] = {}
        self._reported = 0

    def _select(self, topics: Iterable[str] | None) -> dict[str, TopicInfo]:
        known = {topic.name: topic for topic in self.info.topics}
        if topics is None:
            chosen = dict(known)
        else:
            wanted = [topics] if isinstance(topics, str) else list(topics)
            missing = [t for t in wanted if t not in known]
            if missing:
                listed = ", ".join(sorted(known)) or "none"
                raise BagError(
                    f"{self.path}: no topic {', '.join(missing)} in this bag (topics: {listed})"
                )
            chosen = {name: known[name] for name in wanted}
        for topic in chosen.values():
            if topic.serialization_format != "cdr":
                raise BagError(
                    f"{self.path}: topic {topic.name} is serialised as "
                    f"{topic.serialization_format!r}; only 'cdr' can be decoded"
                )
        return chosen

    # -- reading ------------------------------------------------------------------------------
    def __iter__(self) -> Iterator[BagMessage]:
        """Read the bag (again): indices and ``errors`` start afresh with every iteration."""
        self.errors = []
        self._counts = {}
        self._reported = 0
        try:
            for storage in self._storages:
                yield from self._read(storage)
        finally:
            self._report()

    def _read(self, storage: StorageFile) -> Iterator[BagMessage]:
        plans: dict[int, tuple[str, TopicDecoder]] = {}
        for connection in storage.connections():
            if connection.topic in self.topics:
                plans[connection.id] = (connection.topic, self._decoder(connection))
        counts = self._counts
        for connection_id, log_time, data in storage.messages(
            set(plans), self.start_ns, self.end_ns
        ):
            topic, decoder = plans[connection_id]
            index = counts.get(topic, 0)
            counts[topic] = index + 1
            try:
                value = decoder.decode(data)
            except Exception as error:  # any codec failure is one message's problem
                try:
                    value = decoder.recover(data, error)
                except Exception as final:
                    self._problem(topic, index, log_time, final)
                    continue
            yield BagMessage(topic, log_time, value, decoder.msg_type)

    def _decoder(self, connection: Connection) -> TopicDecoder:
        key = (connection.msg_type, connection.definition, connection.definition_encoding)
        decoder = self._decoders.get(key)
        if decoder is None:
            decoder = TopicDecoder(
                connection.msg_type,
                connection.definition,
                connection.definition_encoding,
                natural=self.natural,
            )
            self._decoders[key] = decoder
        return decoder

    def _problem(self, topic: str, index: int, log_time: int, error: Exception) -> None:
        reason = one_line(error)
        if self.on_error == "raise":
            raise DecodeError(f"{self.path}: {topic}[{index}]: {reason}") from error
        self.errors.append(DecodeProblem(topic, index, log_time, reason))

    def _report(self) -> None:
        if not self.errors or self._reported == len(self.errors):
            return
        self._reported = len(self.errors)
        by_topic: dict[str, int] = {}
        for problem in self.errors:
            by_topic[problem.topic] = by_topic.get(problem.topic, 0) + 1
        summary = ", ".join(f"{topic}: {count}" for topic, count in sorted(by_topic.items()))
        _log.warning(
            "%s: %d message(s) not decoded (%s); first: %s",
            self.path,
            len(self.errors),
            summary,
            self.errors[0],
        )

    # -- tables (pyconnect.record.tables; needs the ``tables`` extra) ---------------------------
    def to_arrow(self, topic: str) -> Any:
        """``topic`` as a ``pyarrow.Table``: one row per message, one typed column per field."""
        from pyconnect.record.tables import topic_table

        return topic_table(self, topic, errors=self.errors)

    def to_pandas(self, topic: str) -> Any:
        """``topic`` as a ``pandas.DataFrame`` with the columns of ``to_arrow``."""
        return self.to_arrow(topic).to_pandas()

    def to_polars(self, topic: str) -> Any:
        """``topic`` as a ``polars.DataFrame`` with the columns of ``to_arrow``."""
        import polars

        return polars.from_arrow(self.to_arrow(topic))

    def close(self) -> None:
        """Close the storage files; idempotent."""
        for storage in self._storages:
            storage.close()
        self._storages = []

    def __enter__(self) -> BagReader:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"BagReader({str(self.path)!r}, topics={len(self.topics)})"


def open_bag(
    path: str | Path,
    *,
    topics: Iterable[str] | None = None,
    start_ns: int | None = None,
    end_ns: int | None = None,
    natural: bool = True,
    on_error: OnError = "report",
) -> BagReader:
    """Open a bag for reading: see the module docstring. ``end_ns`` is exclusive."""
    return BagReader(
        path, topics=topics, start_ns=start_ns, end_ns=end_ns, natural=natural, on_error=on_error
    )


def bag_info(path: str | Path) -> BagInfo:
    """Topics, types, message counts and time range of a bag, read from its storage files."""
    located = locate_bag_files(path)
    storages: list[StorageFile] = []
    try:
        storages = [open_storage(p) for p in located.files]
        return _describe(located, storages)
    finally:
        for storage in storages:
            storage.close()
