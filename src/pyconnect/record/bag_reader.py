"""Read rosbag2 bags offline (no ROS graph, no rclpy): ``open_bag`` and ``bag_info``.

``open_bag(path)`` takes a bag directory (with or without metadata.yaml, one or several split
files), one ``.mcap``/``.db3`` file, or a list of those (read merged in log-time order), and
yields one ``BagMessage`` per stored message in log-time order. A ``BagMessage`` is a named
tuple ``(topic, log_time_ns, value)`` (``item.topic``, ``item[0]`` and unpacking all work) with
``.msg_type`` beside it::

    with open_bag("run1", topics=["/odom"]) as bag:
        for topic, stamp_ns, value in bag:
            ...
        print(bag.errors, bag.damage)   # undecodable messages, damaged parts of the files

``topics=`` and ``types=`` select what is read (both given: a topic must match both; of a topic
stored as several types, ``types=`` reads only the messages of the types it names);
``start_ns=`` (inclusive) and ``end_ns=`` (exclusive) the log times, as integer nanoseconds
since the epoch or timezone-aware datetimes (a naive one does not say which instant it is and is
refused); times beyond the int64 range rosbag2 stores are clamped to it.
``raw=True`` yields the CDR bytes as ``value`` undecoded (the type of each topic is
``item.msg_type`` and ``reader.topics[topic].msg_type``). Values come from the wire codecs
(``pyconnect.codecs.wire``): natural values by default (from ``registry``, the default registry
when None), the lossless dict with ``natural=False``. Each topic is decoded with the definition
stored in the bag when there is one, else with the installed type; a stored definition that
does not fit the bytes gives way to the installed type. When the bag stores a RIHS01 type hash
that differs from the installed type's, the mismatch is reported (a warning and
``reader.mismatches``) and the bag's own definition is used, never the installed one.

Nothing is lost silently. A message that cannot be decoded is skipped: the first on each topic
is logged at once (``pyconnect.record`` logger), all are listed in ``reader.errors`` and
summarised in one warning at the end of the read, which goes on; ``on_error="raise"`` raises
``DecodeError`` instead. A damaged file (cut short, a chunk that does not decompress, a wrong
CRC, an index pointing past the end, a ``.db3`` cut short) never raises: every intact message
is delivered, ``reader.damage`` lists what is broken, and one warning at the end of the read
says what, where, and how many messages were read of those the bag's metadata promised. A
metadata.yaml that disagrees with the storage files (a file it does not list, which is not read;
per-topic counts that differ) is reported the same way; a topic it lists that no file holds (a
recording cut before its channels) is still a topic of the bag, with no messages.
Only CDR-serialised topics of a known type can be decoded: selecting another (``topics=``,
``types=``) raises ``BagError`` when the bag is opened (``raw=True`` reads them); a read that
selects no topics leaves them out, listed in ``reader.left_out`` and said in ``reader.notes``
and one warning.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from pyconnect.record.bag_damage import BagDamage
from pyconnect.record.bag_files import BagFiles, BagPaths, open_bag_files
from pyconnect.record.bag_info import (
    BagInfo,
    TopicInfo,
    bag_info,
    describe,
    storage_damage,
)
from pyconnect.record.bag_message import BagMessage, DecodeProblem
from pyconnect.record.bag_read import ConnectionDecoders, MergedRead
from pyconnect.record.bag_read_options import TimeBound, checked_registry, nanoseconds
from pyconnect.record.bag_read_report import OnError, ProblemLog, damage_line
from pyconnect.record.bag_storage import StorageFile
from pyconnect.record.topic_decoder import TopicDecoder, TypeMismatch, normalise_type_name
from pyconnect.record.topic_selection import (
    left_out_note,
    left_out_topics,
    reads_connection,
    select_topics,
    selected_count,
    types_by_topic,
    wanted_types,
)

if TYPE_CHECKING:
    from pyconnect.codecs.registry import Registry

__all__ = [
    "BagInfo",
    "BagMessage",
    "BagReader",
    "DecodeProblem",
    "TopicInfo",
    "TypeMismatch",
    "bag_info",
    "normalise_type_name",
    "open_bag",
]

_log = logging.getLogger("pyconnect.record")


class BagReader:
    """An open bag: iterate it for ``BagMessage``s; ``info`` describes it; close when done.

    See the module docstring for the options; ``open_bag`` is the usual way to make one.
    """

    def __init__(
        self,
        paths: BagPaths,
        *,
        topics: Iterable[str] | None = None,
        types: Iterable[str] | None = None,
        start_ns: TimeBound | None = None,
        end_ns: TimeBound | None = None,
        natural: bool = True,
        raw: bool = False,
        registry: Registry | None = None,
        on_error: OnError = "report",
    ) -> None:
        if on_error not in ("report", "raise"):
            raise ValueError(f"on_error: expected 'report' or 'raise', got {on_error!r}")
        self.on_error: OnError = on_error
        self._problems = ProblemLog(Path(), on_error)
        self.natural = natural
        self.raw = raw
        self.registry = checked_registry(registry)
        self.start_ns = nanoseconds("start_ns", start_ns)
        self.end_ns = nanoseconds("end_ns", end_ns)
        self._bags: list[tuple[BagFiles, list[StorageFile]]] = []
        self._closed_damage: tuple[BagDamage, ...] = ()
        self._borrowed_damage: list[BagDamage] = []  # found by readers of one topic (tables)
        try:
            open_bag_files(paths, into=self._bags, caller="open_bag")
            self.path = self._bags[0][0].path
            self._problems.path = self.path
            self.info = describe(self._bags)
            self.types: frozenset[str] | None = wanted_types(types)
            """``types=`` normalised (``pkg/msg/Name``; None: any): only connections of these
            types are read, of a topic stored as several types too."""
            self.topics = select_topics(
                self.info,
                self.path,
                topics,
                self.types,  # a generator given as types= is read once, above
                raw=raw,
                topic_types=None if types is None else types_by_topic(self._bags),
            )
        except BaseException:
            self.close()
            raise
        self.left_out: dict[str, str] = left_out_topics(self.info, topics, types, raw=raw)
        """Topic -> why it is not read: the topics that cannot be decoded (not serialised as
        CDR, of no type), which a read that selects no topics leaves out."""
        self.notes: list[str] = [left_out_note(self.path, self.left_out)] if self.left_out else []
        """What the reader left out of its own accord, one line each (also logged once)."""
        for note in self.notes:
            _log.warning("%s", note)
        self._decoders = ConnectionDecoders(
            self.path, self.topics, natural=natural, registry=self.registry
        )
        self.mismatches: list[TypeMismatch] = self._decoders.mismatches
        self._delivered = 0
        self._first_decoded: set[int] = set()  # decoders topic_codec has settled
        self.switched: dict[str, int] = {}
        """Topic -> how many of its messages had been delivered, decoded with the definition
        stored in the bag, when a later one needed the installed type (its values then follow
        two definitions). Filled as the bag is read."""

    @property
    def errors(self) -> list[DecodeProblem]:
        """The messages of the last read that could not be decoded, in reading order."""
        return self._problems.errors

    @property
    def bag_paths(self) -> list[Path]:
        """Every bag this reader merges (``open_bag([run1, run2])``), in the order given."""
        return [located.path for located, _storages in self._bags]

    @property
    def damage(self) -> list[BagDamage]:
        """What is broken in the bag's files, as far as they have been read, then where its
        metadata.yaml disagrees with them."""
        found = storage_damage(s for _, storages in self._bags for s in storages)
        own = [*(found or self._closed_damage)]
        seen = {str(item) for item in own}
        borrowed = [item for item in self._borrowed_damage if str(item) not in seen]
        return [*own, *borrowed, *self.info.metadata_damage]

    def note_damage(self, damage: Sequence[BagDamage]) -> None:
        """Add what another reader of the same bags found (``topic_table`` reads one topic with
        a reader of its own): ``damage`` then lists it too, once."""
        known = {str(item) for item in self._borrowed_damage}
        for item in damage:
            if str(item) not in known:
                known.add(str(item))
                self._borrowed_damage.append(item)

    # -- reading ------------------------------------------------------------------------------
    def __iter__(self) -> Iterator[BagMessage]:
        """Read the bag (again): indices, ``errors`` and reports start afresh every time."""
        read = self._start()
        try:
            yield from read.messages(self._problems, self.switched)
        finally:
            self._finish(read)

    def with_codecs(self) -> Iterator[tuple[BagMessage, Any]]:
        """Read the bag as iterating it does, each message with the wire codec its value was
        decoded with (None when ``raw``). That is the codec of the message's own connection:
        of a topic stored with two definitions (two channels, merged bags) there are two, and
        ``topic_codec`` gives the first only."""
        read = self._start()
        try:
            for message in read.messages(self._problems, self.switched):
                yield message, read.codec
        finally:
            self._finish(read)

    def _start(self) -> MergedRead:
        self._problems = ProblemLog(self.path, self.on_error)
        self.switched = {}
        self._delivered = 0
        storages = [storage for _, stored in self._bags for storage in stored]
        decoders = None if self.raw else self._decoders
        return MergedRead(
            storages, self.topics, decoders, self.start_ns, self.end_ns, types=self.types
        )

    def _finish(self, read: MergedRead) -> None:
        self._delivered = read.delivered
        self._report()

    def topic_codec(self, topic: str) -> Any:
        """The wire codec the values of ``topic`` follow (None: none could be built).

        That is the definition stored in the bag, unless it does not fit the topic's first
        message and the installed type does (then the installed type), as reading decides: the
        first message is decoded here to settle it. Its ``definitions`` give the fields. Of a
        topic with several connections (merged bags, split files, two channels), the first's.
        """
        for _, storages in self._bags:
            codec = next(self._codecs(storages, topic), None)
            if codec is not None:
                return codec
        return None

    def topic_codecs(self, topic: str) -> list[tuple[Path, Any]]:
        """Every codec ``topic`` is decoded with, each with the bag it is read from: (bag path,
        codec), in the order of the bags, their files and connections; each once per bag.

        Per connection, not per bag: one bag may hold the topic as two types or definitions
        (two MCAP channels of one topic), which one table cannot hold.
        """
        found: list[tuple[Path, Any]] = []
        for located, storages in self._bags:
            seen: set[int] = set()  # ids of codecs found in this bag (split files share them)
            for codec in self._codecs(storages, topic):
                if id(codec) not in seen:
                    seen.add(id(codec))
                    found.append((located.path, codec))
        return found

    def _codecs(self, storages: Sequence[StorageFile], topic: str) -> Iterator[Any]:
        """The codec of each connection of ``topic`` in ``storages`` that has one (of those
        ``types=`` lets the reader read)."""
        for storage in storages:
            for connection in storage.connections():
                if not reads_connection(connection, (topic,), self.types):
                    continue
                decoder = self._decoders.decoder(connection)
                # Once per decoder: align asks for every matched message, and a stored
                # definition that fits never counts as settled.
                if not decoder.settled and id(decoder) not in self._first_decoded:
                    self._first_decoded.add(id(decoder))
                    self._settle(decoder, storage, connection.id)
                if decoder.codec is not None:
                    yield decoder.codec

    def _settle(self, decoder: TopicDecoder, storage: StorageFile, connection_id: int) -> None:
        stream = storage.messages({connection_id}, self.start_ns, self.end_ns)
        try:
            for _id, _log_time, data in stream:
                try:
                    decoder.decode(data)
                except Exception as error:  # reading reports it; here only choose the codec
                    try:
                        decoder.recover(data, error)
                    except Exception:
                        continue  # undecodable either way: the next message decides
                return
        finally:
            stream.close()  # type: ignore[attr-defined]  # a generator

    def _report(self) -> None:
        self._problems.log_summary()
        damage = self.damage
        if damage:
            _log.warning("%s", self.damage_summary(damage))

    def damage_summary(
        self, damage: Sequence[BagDamage] | None = None, *, read: int | None = None
    ) -> str:
        """One line: what is damaged, where, and how many messages were read of those promised
        (``read``: when they were read by other readers of the same bag, as tables are)."""
        found = self.damage if damage is None else list(damage)
        read = self._delivered if read is None else read
        promised = selected_count(self._bags, self.topics, self.types)
        return damage_line(self.path, found, read, promised)

    # -- tables (pyconnect.record.tables; needs the ``tables`` extra) ---------------------------
    def to_arrow(
        self,
        topic: str,
        *,
        images: Literal["binary", "files"] = "binary",
        image_dir: str | Path | None = None,
    ) -> Any:
        """``topic`` as a ``pyarrow.Table``: one row per message, one typed column per field.

        ``images="files"`` writes each image to a lossless PNG (or ``.npy``) file under
        ``image_dir`` and gives a ``data_path`` column (relative to ``image_dir``) in place of
        the binary ``data`` (``pyconnect.record.image_files``).
        """
        from pyconnect.record.tables import topic_table

        return topic_table(self, topic, errors=self.errors, images=images, image_dir=image_dir)

    def to_pandas(
        self,
        topic: str,
        *,
        images: Literal["binary", "files"] = "binary",
        image_dir: str | Path | None = None,
    ) -> Any:
        """``topic`` as a ``pandas.DataFrame`` with the columns of ``to_arrow``; an integer or bool
        column with nulls (merged bags of two definitions of the type) has a pandas nullable dtype
        (``UInt64``, ``boolean``), so its values stay exact (``pyconnect.record.table_pandas``)."""
        from pyconnect.record.table_pandas import table_to_pandas

        return table_to_pandas(self.to_arrow(topic, images=images, image_dir=image_dir))

    def to_polars(
        self,
        topic: str,
        *,
        images: Literal["binary", "files"] = "binary",
        image_dir: str | Path | None = None,
    ) -> Any:
        """``topic`` as a ``polars.DataFrame`` with the columns of ``to_arrow``."""
        import polars

        return polars.from_arrow(self.to_arrow(topic, images=images, image_dir=image_dir))

    def close(self) -> None:
        """Close the storage files; idempotent. ``damage`` still lists what they held."""
        self._closed_damage = self._closed_damage or storage_damage(
            s for _, storages in self._bags for s in storages
        )
        for _, storages in self._bags:
            for storage in storages:
                storage.close()
            storages.clear()

    def __enter__(self) -> BagReader:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"BagReader({str(self.path)!r}, topics={len(self.topics)})"


def open_bag(
    path: BagPaths,
    *,
    topics: Iterable[str] | None = None,
    types: Iterable[str] | None = None,
    start_ns: TimeBound | None = None,
    end_ns: TimeBound | None = None,
    natural: bool = True,
    raw: bool = False,
    registry: Registry | None = None,
    on_error: OnError = "report",
) -> BagReader:
    """Open one bag or several (merged in time order): see the module docstring.

    ``end_ns`` is exclusive.
    """
    return BagReader(
        path,
        topics=topics,
        types=types,
        start_ns=start_ns,
        end_ns=end_ns,
        natural=natural,
        raw=raw,
        registry=registry,
        on_error=on_error,
    )
