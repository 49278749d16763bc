"""``SplitRecorder``: a rosbag2 bag directory written as MCAP files split by size or duration.

``SplitRecorder("run1", max_bytes=..., max_ns=...)`` writes ``run1/run1_0.mcap``,
``run1/run1_1.mcap``, ... and ``run1/metadata.yaml`` (what ``pyconnect bag record`` writes, from
a thread of its own: ``pyconnect.record.queued_recorder``). The first file is opened, and each
topic's definition read, when the first topic is added, so that the first message written costs
no more than the others; later files reuse the definitions.

``max_bytes`` is a file size, as ``ros2 bag record -b`` has it: the bytes written to the file so
far (``McapRecorder.bytes_written``). Messages reach the file in compressed chunks, so a file
grows a chunk at a time and is split at the first chunk that takes it to the limit (as rosbag2's
MCAP files are); chunks hold at most ``max_bytes`` of uncompressed messages (and 1 MiB), so a
small limit still gives files of about that size.

No file of the bag can be lost, whenever the recording stops:

- ``metadata.yaml`` lists every file from the moment it is created: it is rewritten (atomically)
  each time a file is opened, so a process killed mid-recording leaves a bag whose metadata names
  every file; the last one is then cut short, and ``open_bag`` reads every message in it and
  reports the damage (``ros2 bag reindex`` is not needed);
- the state changes in an order where an exception (or ``KeyboardInterrupt``) at any point leaves
  something ``close()`` can finish: a file's name is reserved before the file is created, and
  ``close()`` finishes the open file, lists a file whose creation was cut short when it holds an
  MCAP header, and removes it when it does not;
- ``close()`` writes the final metadata (counts, times); it is idempotent.

A split costs the same with the thousandth file as with the first: a finished file's recorder
(its schemas and indexes) is let go, and its items in metadata.yaml are written as YAML once,
then reused by every later rewrite (``pyconnect.record.split_files``).

A file that could not be written whole (a full disk: a chunk or its end cut short) is read back
when it is finished, and its messages counted as a reader finds them: ``counts`` and
metadata.yaml then say what the bag holds, not what was handed to it. ``close()`` then raises
the failure, after writing the metadata if the disk has room for it (else the bag is left with
no metadata.yaml rather than one that contradicts its files); no later ``close()`` retries.

A directory removed while it is recorded is not made again (empty, at the next split, to hold
the rest of a bag whose metadata would list files that are gone): the next file, or the
metadata, cannot be written, and that is a ``BagError`` saying so; the counts are then 0, as
the bag's files went with it.

``write`` and ``add_topic`` are thread-safe.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from pathlib import Path

from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_metadata import METADATA_FILE, BagMetadata, TopicMetadata, write_metadata
from pyconnect.record.mcap_recorder import DEFAULT_CHUNK_SIZE, McapRecorder
from pyconnect.record.split_files import FinishedFiles, SplitFile

__all__ = ["SplitRecorder"]

_MCAP_MAGIC = b"\x89MCAP0\r\n"


@dataclass
class _Topic:
    msg_type: str
    qos: str
    definition: str
    type_hash: str  # RIHS01, "" when unknown: every file's channel and metadata.yaml store it
    count: int = 0


class SplitRecorder:
    """Record raw CDR messages into a new bag directory, one MCAP file per split.

    ``max_bytes`` (the file's size: bytes written to it, see the module docstring) and
    ``max_ns`` (log time since the file's first message) start a new file when reached; 0 never
    does, a negative one raises ``ValueError``. A file holds at least one message.
    """

    def __init__(
        self,
        directory: str | Path,
        *,
        max_bytes: int = 0,
        max_ns: int = 0,
        compression: str = "zstd",
    ) -> None:
        # A negative limit is always reached: every message would get a file of its own.
        for name, limit in (("max_bytes", max_bytes), ("max_ns", max_ns)):
            if limit < 0:
                raise ValueError(f"{name}: expected 0 (no split) or more, got {limit}")
        self.directory = Path(directory)
        self.max_bytes = max_bytes
        self.max_ns = max_ns
        self.compression = compression
        self.chunk_size = min(max_bytes, DEFAULT_CHUNK_SIZE) if max_bytes else DEFAULT_CHUNK_SIZE
        self._names: list[str] = []  # every file's, in order; the last one may be open
        self._last: SplitFile | None = None  # the last file, until it is finished
        self._finished = FinishedFiles()
        self._topics: dict[str, _Topic] = {}
        self._lock = threading.Lock()
        self._closed = False
        self._removed: BagError | None = None  # raised once the directory is found gone
        if self.directory.exists() and (
            not self.directory.is_dir() or any(self.directory.iterdir())
        ):
            raise BagError(f"{self.directory}: already exists; a new recording needs a new one")
        self.directory.mkdir(parents=True, exist_ok=True)

    @property
    def counts(self) -> dict[str, int]:
        """Messages written per topic."""
        return {name: topic.count for name, topic in self._topics.items()}

    @property
    def files(self) -> list[str]:
        """The names of the bag's files so far, in order."""
        return list(self._names)

    def add_topic(
        self,
        topic: str,
        msg_type: str,
        *,
        offered_qos_profiles: str = "",
        definition: str | None = None,
        type_hash: str = "",
    ) -> None:
        """Declare a topic (to the open file and every later one), opening the first file.

        ``definition`` is the ros2msg text (None: built from the installed interface files,
        here, so that no later write or split has to). ``type_hash`` is the type's RIHS01 hash
        as rosbag2 stores it ("": none), the publishers' (``recording_qos.offered_type_hash``).
        """
        if topic in self._topics:
            return
        if definition is None:
            from pyconnect.typesys.installed_definition_text import installed_definition
            from pyconnect.typesys.names import full_type_name

            # Outside the lock: reading interface files must not hold up a write meanwhile.
            definition = installed_definition(full_type_name(msg_type))
        with self._lock:
            self._check_open()
            if topic in self._topics:
                return
            known = _Topic(msg_type, offered_qos_profiles, definition, type_hash)
            self._topics[topic] = known
            current = self._current()
            try:
                if current is None or current.recorder is None:
                    self._open_next()  # adds every topic, this one included
                else:
                    self._add_to(current.recorder, topic, known)
            except OSError as error:
                self._raise_if_removed(error)
                raise

    def write(self, topic: str, data: bytes, *, log_time_ns: int) -> None:
        """Append one message, starting the next file first when the open one is full."""
        with self._lock:
            self._check_open()
            known = self._topics.get(topic)
            if known is None:
                raise BagError(f"{topic}: not added to this recording; call add_topic first")
            current = self._current()
            if current is None or current.recorder is None or self._full(current, log_time_ns):
                try:
                    current = self._open_next()
                except OSError as error:
                    self._raise_if_removed(error)
                    raise
            assert current.recorder is not None
            try:
                current.recorder.write(topic, data, log_time_ns=log_time_ns)
            except OSError:  # the chunk it closed may be cut short, earlier messages with it
                current.failed = True
                raise
            known.count += 1
            current.count += 1
            current.topics[topic] = current.topics.get(topic, 0) + 1
            if current.first_ns is None:
                current.first_ns = log_time_ns
            current.last_ns = log_time_ns

    def close(self) -> None:
        """Finish the open file and write the final metadata.yaml; idempotent."""
        with self._lock:
            if self._closed:
                return
            try:
                if not self._names:
                    self._open_next()  # an empty recording is still a valid bag
            except OSError as error:
                self._raise_if_removed(error)
                raise
            try:
                self._finish_current()
            except Exception as error:  # Ctrl-C is not: close() finishes the file then
                # The file is what it is (and recounted): finishing it again cannot help.
                self._closed = True
                self._write_metadata_if_room()  # the failure raised says the disk is full
                if isinstance(error, OSError):
                    self._raise_if_removed(error)
                raise
            failure = self._write_metadata_if_room()
            self._closed = True
            if failure is not None:
                self._raise_if_removed(failure)
                raise failure

    def _raise_if_removed(self, error: OSError) -> None:
        """Raise a ``BagError`` (the same one each time) when ``error`` is the directory's being
        gone: it was removed while it was recorded."""
        if self.directory.is_dir():
            return
        # Its files went with it: the bag holds none of the messages written to them.
        for known in self._topics.values():
            known.count = 0
        if self._removed is None:
            self._removed = BagError(
                f"{self.directory}: the directory was removed while it was recorded, "
                "its files with it"
            )
        raise self._removed from error

    # -- files --------------------------------------------------------------------------------
    def _current(self) -> SplitFile | None:
        """The last file while it is not finished (its recorder may not exist yet)."""
        if self._last is None or len(self._finished.entries) == len(self._names):
            return None
        return self._last

    def _full(self, current: SplitFile, now_ns: int) -> bool:
        if not current.count:
            return False  # a new file's header alone may pass a tiny max_bytes
        assert current.recorder is not None
        if self.max_bytes and current.recorder.bytes_written >= self.max_bytes:
            return True
        first = current.first_ns
        return bool(self.max_ns and first is not None and now_ns - first >= self.max_ns)

    def _open_next(self) -> SplitFile:
        self._finish_current()
        file = SplitFile(f"{self.directory.name}_{len(self._names)}.mcap")
        self._last = file  # before its name: until then it is not the last file, not open
        self._names.append(file.name)  # reserved before it exists: close() sees it either way
        file.recorder = McapRecorder(
            self.directory / file.name,
            compression=self.compression,
            chunk_size=self.chunk_size,
            make_parents=False,  # a directory removed meanwhile is an error, not made anew
        )
        for topic, known in self._topics.items():
            self._add_to(file.recorder, topic, known)
        self._write_metadata()  # the new file is listed before a message goes into it
        return file

    @staticmethod
    def _add_to(recorder: McapRecorder, topic: str, known: _Topic) -> None:
        recorder.add_topic(
            topic,
            known.msg_type,
            definition=known.definition,
            offered_qos_profiles=known.qos,
            type_hash=known.type_hash,
        )

    def _finish_current(self) -> None:
        current = self._current()
        if current is None:
            self._last = None  # finished already (an interrupt came before it was let go)
            return
        if current.recorder is not None:
            try:
                current.recorder.close()
            except Exception:
                current.failed = True
                raise
            finally:
                if current.failed:
                    self._recount(current)
        else:
            # Its creation was cut short: keep it when it is an MCAP file (the reader recovers
            # what it holds), drop it when it never got its header.
            path = self.directory / current.name
            try:
                with path.open("rb") as stream:
                    started = stream.read(len(_MCAP_MAGIC)) == _MCAP_MAGIC
            except FileNotFoundError:
                started = False
            if not started:
                path.unlink(missing_ok=True)
                self._names.pop()
                self._last = None
                return
        self._finished.add(current)
        self._last = None  # its recorder's schemas and indexes go: ~10 kB a file, kept for days

    def _recount(self, file: SplitFile) -> None:
        """Count ``file``'s messages as its recorder found them when it read the file back (it
        could not be written whole)."""
        assert file.recorder is not None
        found = {topic: count for topic, count in file.recorder.counts.items() if count}
        # A message whose write failed may be in the file as well as one counted may not be.
        for topic in {*file.topics, *found}:
            self._topics[topic].count += found.get(topic, 0) - file.topics.get(topic, 0)
        file.topics = found
        file.count = sum(found.values())
        span = file.recorder.span
        file.first_ns, file.last_ns = (None, 0) if span is None else span

    def _write_metadata_if_room(self) -> OSError | None:
        """Write the final metadata.yaml on a disk that may be full; the error when it cannot."""
        try:
            self._write_metadata()
        except OSError:
            # No room for the new copy an atomic write makes beside the old one. The old one
            # goes (its counts are not the files'): its room may take the new one, and a bag
            # without metadata.yaml is still read from its files, with nothing to contradict.
            (self.directory / METADATA_FILE).unlink(missing_ok=True)
            try:
                self._write_metadata()
            except OSError as error:
                return error
        return None

    def _write_metadata(self) -> None:
        current = self._current()
        unfinished = () if current is None else (current,)
        spans = [(file.first_ns or 0, file.last_ns) for file in unfinished if file.count]
        if self._finished.span is not None:
            spans.append(self._finished.span)
        start = min((first for first, _last in spans), default=0)
        end = max((last for _first, last in spans), default=start)
        metadata = BagMetadata(
            storage_identifier="mcap",
            relative_file_paths=tuple(file.name for file in unfinished),
            topics=tuple(
                TopicMetadata(
                    name=name,
                    msg_type=topic.msg_type,
                    offered_qos_profiles=topic.qos,
                    type_description_hash=topic.type_hash,
                    message_count=topic.count,
                )
                for name, topic in self._topics.items()
            ),
            starting_time_ns=start,
            duration_ns=end - start,
            message_count=sum(topic.count for topic in self._topics.values()),
            files=tuple(file.entry() for file in unfinished),
        )
        preceding = self._finished.lists()
        write_metadata(self.directory / METADATA_FILE, metadata, preceding=preceding)

    def _check_open(self) -> None:
        if self._closed:
            raise BagError(f"{self.directory}: recording is closed")

    def __enter__(self) -> SplitRecorder:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
