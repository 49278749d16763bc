"""``McapRecorder``: write raw CDR messages to an MCAP file with ros2msg schemas (rosbag2 layout).

``McapRecorder("run1")`` writes the directory ``run1/`` holding ``run1_0.mcap`` and, on
``close()``, ``metadata.yaml`` (version 8), as ``ros2 bag record -s mcap`` does.
``McapRecorder("run1.mcap")`` writes that one file and no metadata (``ros2 bag``, rosbags and
Foxglove read bare MCAP files). The container is the ``mcap`` package's writer with the "ros2"
profile, "ros2msg" schemas ("ros2idl" for types defined in .idl), "cdr" messages and zstd (or
lz4, or no) chunk compression. As rosbag2's MCAP storage does on closing a file, a "rosbag2"
metadata record holds the bag's metadata as YAML (``serialized_metadata``).

A file that could not be written whole (a write or its finishing failed: a full disk) is read
back when it is closed, and its messages counted as a reader finds them: ``counts``,
``messages_written`` and metadata.yaml then say what it holds, not what it was handed.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

from mcap.writer import CompressionType, Writer

from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_metadata import (
    METADATA_FILE,
    BagMetadata,
    TopicMetadata,
    metadata_info,
    metadata_yaml,
    write_metadata,
)
from pyconnect.typesys.names import full_type_name

__all__ = ["DEFAULT_CHUNK_SIZE", "McapRecorder"]

DEFAULT_CHUNK_SIZE = 1024 * 1024

_COMPRESSION = {
    "zstd": CompressionType.ZSTD,
    "lz4": CompressionType.LZ4,
    "none": CompressionType.NONE,
    "": CompressionType.NONE,
}


class _CountedFile:
    """The file the MCAP writer writes to, counting what it is given: the file's size so far.

    The writer asks ``tell()`` for chunk offsets; the file is new, so the count is the position,
    without a system call per question.
    """

    def __init__(self, stream: BinaryIO) -> None:
        self.stream = stream
        self.written = 0

    def write(self, data: bytes) -> int:
        count = self.stream.write(data)
        self.written += count
        return count

    def tell(self) -> int:
        return self.written

    def flush(self) -> None:
        self.stream.flush()

    def close(self) -> None:
        self.stream.close()


@dataclass
class _Topic:
    name: str
    msg_type: str
    channel_id: int
    offered_qos_profiles: str
    type_hash: str = ""
    count: int = 0


class McapRecorder:
    """Record CDR messages of any number of topics; ``write`` is thread-safe.

    Call ``add_topic`` once per topic before writing it; ``definition`` is the definition text
    (built from the installed interface files when None): ros2msg, or ros2idl when it is laid
    out as ``installed_definition_text.installed_definition`` writes IDL. ``chunk_size`` is the
    uncompressed size at which a chunk is closed and compressed. ``close()`` finishes the file and
    writes metadata.yaml; it is idempotent and also runs on leaving a ``with`` block.
    ``make_parents=False`` leaves the folder of a ``.mcap`` path as it is: a missing one is an
    error (a split bag's directory removed while it was recorded), not made anew and empty.
    """

    def __init__(
        self,
        path: str | Path,
        *,
        compression: str = "zstd",
        chunk_size: int = DEFAULT_CHUNK_SIZE,
        registry: Any = None,
        make_parents: bool = True,
    ) -> None:
        self.registry = registry
        if compression not in _COMPRESSION:
            choices = ", ".join(repr(c) for c in _COMPRESSION if c)
            raise ValueError(f"compression: expected one of {choices}, got {compression!r}")
        target = Path(path)
        if target.suffix == ".mcap":
            self.bag_dir: Path | None = None
            self.file_path = target
            if make_parents:
                target.parent.mkdir(parents=True, exist_ok=True)
        else:
            if target.exists() and (not target.is_dir() or any(target.iterdir())):
                raise BagError(f"{target}: already exists; a new recording needs a new directory")
            target.mkdir(parents=True, exist_ok=True)
            self.bag_dir = target
            self.file_path = target / f"{target.name}_0.mcap"
        if self.file_path.exists():
            raise BagError(f"{self.file_path}: already exists; not overwriting a recording")
        self._lock = threading.Lock()
        self._stream: BinaryIO = open(self.file_path, "wb")  # noqa: SIM115 - closed by close()
        self._counted = _CountedFile(self._stream)
        try:
            self._writer = Writer(
                self._counted,  # type: ignore[arg-type]  # a file as far as the writer uses one
                compression=_COMPRESSION[compression],
                chunk_size=chunk_size,
            )
            self._writer.start(profile="ros2", library="pyconnect")
            # On disk at once: a process killed now leaves an MCAP file a reader recovers
            # (open_bag reads a file cut short), not an empty one that is no bag at all.
            self._stream.flush()
        except BaseException:  # Ctrl-C included: the file must not stay open
            self._stream.close()
            raise
        self._schemas: dict[tuple[str, str], int] = {}
        self._topics: dict[str, _Topic] = {}
        self._first_ns: int | None = None
        self._last_ns: int | None = None
        self._closed = False
        self.messages_written = 0
        self.failed = False
        """A write or finishing the file failed: it may miss messages it was given (a chunk cut
        short); ``close()`` reads it back."""

    @property
    def bytes_written(self) -> int:
        """The file's size so far: its header, and each chunk once it is closed (compressed)
        with its indexes; the chunk being filled is in memory and not counted yet. This is what
        ``ros2 bag record -b`` measures (rosbag2's MCAP storage asks its writer the same)."""
        return self._counted.written

    @property
    def topics(self) -> dict[str, str]:
        """Topic name -> type of every added topic."""
        return {name: topic.msg_type for name, topic in self._topics.items()}

    @property
    def counts(self) -> dict[str, int]:
        """Topic name -> messages written (after a failed ``close()``: found in the file)."""
        return {name: topic.count for name, topic in self._topics.items()}

    @property
    def span(self) -> tuple[int, int] | None:
        """The first and last log time of the messages counted (None: there are none)."""
        if self._first_ns is None or self._last_ns is None:
            return None
        return self._first_ns, self._last_ns

    def add_topic(
        self,
        topic: str,
        msg_type: str,
        *,
        definition: str | None = None,
        offered_qos_profiles: str = "",
        type_hash: str | None = None,
    ) -> None:
        """Declare a topic; adding it again with the same type does nothing, another type raises.

        ``type_hash`` (RIHS01), when given, is stored for readers to compare with their installed
        type. None stores none: rosbags recomputes hashes from the definition text and refuses
        a bag where its result differs (it does for ``test_msgs/BasicTypes``).
        """
        full_type = full_type_name(msg_type)
        with self._lock:
            self._check_open()
            known = self._topics.get(topic)
            if known is not None:
                if known.msg_type != full_type:
                    raise BagError(
                        f"{topic}: already recorded as {known.msg_type}, cannot add it as "
                        f"{full_type}"
                    )
                return
            from pyconnect.typesys.installed_definition_text import (
                definition_encoding,
                installed_definition,
            )

            if definition is None:
                definition = installed_definition(full_type)
            key = (full_type, definition)
            schema_id = self._schemas.get(key)
            if schema_id is None:
                schema_id = self._writer.register_schema(
                    name=full_type,
                    encoding=definition_encoding(definition),
                    data=definition.encode("utf-8"),
                )
                self._schemas[key] = schema_id
            channel_id = self._writer.register_channel(
                topic=topic,
                message_encoding="cdr",
                schema_id=schema_id,
                metadata={
                    "offered_qos_profiles": offered_qos_profiles,
                    "topic_type_hash": type_hash or "",
                },
            )
            self._topics[topic] = _Topic(
                topic, full_type, channel_id, offered_qos_profiles, type_hash or ""
            )

    def write_value(
        self, topic: str, value: Any, *, log_time_ns: int, publish_time_ns: int | None = None
    ) -> None:
        """Encode the topic's natural value (with ``registry``'s codecs) and write it; for a
        type without a natural codec that is its lossless dict (``wire.encode``)."""
        from pyconnect.codecs import wire

        known = self._topics.get(topic)
        if known is None:
            raise BagError(f"{topic}: not added to this recording; call add_topic first")
        cdr = wire.encode(value, known.msg_type, registry=self.registry)
        self.write(topic, cdr, log_time_ns=log_time_ns, publish_time_ns=publish_time_ns)

    def write(
        self, topic: str, cdr: bytes, *, log_time_ns: int, publish_time_ns: int | None = None
    ) -> None:
        """Append one serialised message (with its 4-byte CDR header) of an added topic."""
        with self._lock:
            self._check_open()
            known = self._topics.get(topic)
            if known is None:
                raise BagError(f"{topic}: not added to this recording; call add_topic first")
            try:
                self._writer.add_message(
                    channel_id=known.channel_id,
                    log_time=log_time_ns,
                    data=bytes(cdr),
                    publish_time=log_time_ns if publish_time_ns is None else publish_time_ns,
                    sequence=known.count,
                )
            except OSError:  # the chunk it closed may be cut short, earlier messages with it
                self.failed = True
                raise
            known.count += 1
            self.messages_written += 1
            if self._first_ns is None or log_time_ns < self._first_ns:
                self._first_ns = log_time_ns
            if self._last_ns is None or log_time_ns > self._last_ns:
                self._last_ns = log_time_ns

    def close(self) -> None:
        """Finish the MCAP file and write metadata.yaml (for a bag directory); idempotent.

        When the file could not be written whole, it is read back and counted first; a failure
        is raised after metadata.yaml is written if the disk has room for it (else the bag has
        none, rather than one that contradicts its file). No later ``close()`` retries.
        """
        with self._lock:
            if self._closed:
                return
            self._closed = True
            failure: Exception | None = None
            try:
                self._finish()
            except Exception as error:  # Ctrl-C is not: it ends close() after the count
                failure = error
                self.failed = True
            finally:
                if self.failed:
                    self._recount()
            if self.bag_dir is not None:
                try:
                    write_metadata(self.bag_dir / METADATA_FILE, self._metadata())
                except OSError as error:
                    if failure is None:
                        failure = error
                        if not self.failed:  # the file may be gone too, with its directory
                            self.failed = True
                            self._recount()
            if failure is not None:
                raise failure

    def _finish(self) -> None:
        """Write the rosbag2 metadata record and the file's summary, and close it."""
        try:
            serialized = metadata_yaml(metadata_info(self._metadata()))
            self._writer.add_metadata("rosbag2", {"serialized_metadata": serialized})
            self._writer.finish()  # type: ignore[no-untyped-call]
        finally:
            self._stream.close()

    def _recount(self) -> None:
        """Count the messages as a reader finds them in the file (it could not be written
        whole): a message whose write failed may be in it as well as one counted may not be."""
        from pyconnect.record.mcap_storage import McapFile

        found: dict[str, int] = {}
        first: int | None = None
        last: int | None = None
        try:
            storage = McapFile(self.file_path)
        except (OSError, BagError):  # gone, or not even its header: it holds no message
            storage = None
        if storage is not None:
            try:
                topics = {c.id: c.topic for c in storage.connections()}
                for connection_id, log_time_ns, _data in storage.messages(set(topics), None, None):
                    topic = topics[connection_id]
                    found[topic] = found.get(topic, 0) + 1
                    first = log_time_ns if first is None else min(first, log_time_ns)
                    last = log_time_ns if last is None else max(last, log_time_ns)
            finally:
                storage.close()
        for name, known in self._topics.items():
            known.count = found.get(name, 0)
        self.messages_written = sum(found.values())
        self._first_ns, self._last_ns = first, last

    def _metadata(self) -> BagMetadata:
        start = self._first_ns or 0
        duration = (self._last_ns - start) if self._last_ns is not None else 0
        relative = self.file_path.name
        return BagMetadata(
            storage_identifier="mcap",
            relative_file_paths=(relative,),
            topics=tuple(
                TopicMetadata(
                    name=topic.name,
                    msg_type=topic.msg_type,
                    offered_qos_profiles=topic.offered_qos_profiles,
                    type_description_hash=topic.type_hash,
                    message_count=topic.count,
                )
                for topic in self._topics.values()
            ),
            starting_time_ns=start,
            duration_ns=duration,
            message_count=self.messages_written,
            files=(
                {
                    "path": relative,
                    "starting_time": {"nanoseconds_since_epoch": start},
                    "duration": {"nanoseconds": duration},
                    "message_count": self.messages_written,
                },
            ),
        )

    def _check_open(self) -> None:
        if self._closed:
            raise BagError(f"{self.file_path}: recording is closed")

    def __enter__(self) -> McapRecorder:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "closed" if self._closed else "open"
        return f"McapRecorder({str(self.file_path)!r}, {state}, {self.messages_written} messages)"
