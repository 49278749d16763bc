"""Read rosbag2 sqlite3 (``.db3``) files of every schema version, read-only and immutable.

Schema versions differ in columns (``offered_qos_profiles`` appeared in Eloquent,
``type_description_hash`` and the ``message_definitions`` table in Iron); column lists are read
from the file rather than assumed. The file is opened read-only and immutable, and its tables
found, however damaged it is (cut short, a damaged schema: ``pyconnect.record.sqlite_open``).

Counts and times come from a scan of the ``messages`` table itself, which reads every row's
record header but not its blob: the index and a count that reads less still list rows that
cannot be read. When pages of the ``messages`` table are unreadable, rows are read one batch at
a time in id order, stepping over the unreadable ranges (``pyconnect.record.sqlite_salvage``);
every readable row is delivered and the damage is noted in ``damage``
(``pyconnect.record.bag_damage``), never raised. A flipped byte can
also leave a page SQLite still reads with wrong values in it: text that is not UTF-8 (read with
replacement characters), a NULL, text or blob where an integer belongs; such rows are damage too
(skipped and noted), never a ``UnicodeDecodeError`` or ``TypeError``.
"""

from __future__ import annotations

from collections.abc import Generator, Iterator, Sequence
from pathlib import Path
from typing import Any

from pyconnect.record.bag_damage import DamageLog
from pyconnect.record.bag_storage import Connection, RawMessage
from pyconnect.record.message_compression import readable
from pyconnect.record.sqlite_open import NOTHING_READABLE, SqliteDatabase, columns_of
from pyconnect.record.sqlite_salvage import (
    READ_ERRORS,
    DamagedRow,
    integer_of,
    reason_of,
    row_filter,
    salvage_rows,
)

__all__ = ["SqliteFile"]

_DEFINITION_ENCODINGS = ("ros2msg", "ros2idl")


def _tally_query(messages: str) -> str:
    # typeof(data) reads a row's whole record header (not its blob), which a damaged row fails
    # while COUNT(*) or topic_id alone read past it; the inner query runs as a coroutine, the
    # LIMIT keeping SQLite from flattening it into the GROUP BY, whose sorter would copy every
    # blob. NOT INDEXED: the timestamp index still lists rows whose table page is lost.
    return (
        "SELECT topic_id, COUNT(*), MIN(timestamp), MAX(timestamp), SUM(bad), SUM(id) FROM ("
        "SELECT rowid AS id, topic_id, timestamp, "
        "typeof(timestamp) <> 'integer' OR typeof(data) <> 'blob'"
        f" AS bad FROM {messages} NOT INDEXED LIMIT -1) GROUP BY topic_id"
    )


def _index_query(messages: str) -> str:
    # The index ``messages()`` reads in time order (a covering index: no table row is read).
    return (
        "SELECT COUNT(*), SUM(id), SUM(typeof(timestamp) <> 'integer') FROM ("
        f"SELECT rowid AS id, timestamp FROM {messages} ORDER BY timestamp LIMIT -1)"
    )


class SqliteFile:
    """One ``.db3`` file of a rosbag2 bag."""

    def __init__(self, path: Path, *, message_compression: str = "") -> None:
        self.path = str(path)
        self.damage = DamageLog(self.path)
        self._message_compression = message_compression  # BagFiles.message_compression
        self.promised: int | None = None
        self._connections: list[Connection] = []
        self._tables: dict[str, str] = {}  # rosbag2's name -> the file's, quoted ({}: none read)
        self._tallied: tuple[dict[int, int], tuple[int, int] | None] | None = None
        self._ranges_noted = False  # every unreadable range of the messages table is noted
        self._database = SqliteDatabase(path, self.damage)
        self._db = self._database.db
        self._damaged = self._database.cut
        tables = self._database.tables
        if not {"topics", "messages"} <= tables.keys():
            return  # the damage says why
        self._tables = tables
        try:
            self._connections = self._read_connections()
        except READ_ERRORS as error:
            self._found_damage(error)
            self.damage.note(None, f"the topics table is unreadable: {NOTHING_READABLE}")

    def _read_connections(self) -> list[Connection]:
        columns = columns_of(self._db, self._tables["topics"])
        qos = "offered_qos_profiles" if "offered_qos_profiles" in columns else "''"
        type_hash = "type_description_hash" if "type_description_hash" in columns else "''"
        rows = self._db.execute(
            f"SELECT rowid, name, type, serialization_format, {qos}, {type_hash} "
            f"FROM {self._tables['topics']}"
        ).fetchall()
        definitions = self._tables.get("message_definitions")
        by_hash, by_type = self._read_definitions(definitions) if definitions else ({}, {})
        ids = [row[0] for row in rows]
        connections = []
        for topic_id, name, msg_type, serialization, offered_qos, stored_hash in rows:
            # A damaged id can repeat another: neither says which topic its messages are.
            if ids.count(topic_id) > 1 or not (
                isinstance(topic_id, int) and isinstance(name, str) and isinstance(msg_type, str)
            ):
                self._damaged_row("topics")  # its messages cannot be told apart from noise
                continue
            topic_hash = stored_hash if isinstance(stored_hash, str) else ""
            found = by_hash.get(topic_hash) if topic_hash else None
            if found is None:
                found = by_type.get(msg_type)
            if found is None and msg_type.endswith("_Event") and "/srv/" in msg_type:
                # rosbag2 files a service event's definition under the service's name.
                found = by_type.get(msg_type[: -len("_Event")])
            text, encoding = found if found is not None else (None, "ros2msg")
            connections.append(
                Connection(
                    id=int(topic_id),
                    topic=str(name),
                    msg_type=str(msg_type),
                    serialization_format=str(serialization),
                    definition=text,
                    definition_encoding=encoding,
                    offered_qos_profiles=offered_qos if isinstance(offered_qos, str) else "",
                    type_hash=topic_hash,
                )
            )
        return connections

    def _read_definitions(
        self, table: str
    ) -> tuple[dict[str, tuple[str, str]], dict[str, tuple[str, str]]]:
        """(definition by type hash, by type name); damage leaves the installed types to decode."""
        by_hash: dict[str, tuple[str, str]] = {}
        by_type: dict[str, tuple[str, str]] = {}
        try:
            for topic_type, encoding, text, definition_hash in self._db.execute(
                "SELECT topic_type, encoding, encoded_message_definition, type_description_hash "
                f"FROM {table}"
            ):
                if not (isinstance(topic_type, str) and isinstance(text, str)):
                    self._damaged_row("message_definitions")
                elif encoding in _DEFINITION_ENCODINGS:
                    by_type[topic_type] = (text, encoding)
                    if isinstance(definition_hash, str) and definition_hash:
                        by_hash[definition_hash] = (text, encoding)
        except READ_ERRORS as error:
            self.damage.note(
                None,
                f"the message_definitions table is unreadable ({reason_of(error)}); the installed "
                "types decode what it would have defined",
                key="definitions",
            )
        return by_hash, by_type

    def connections(self) -> Sequence[Connection]:
        return self._connections

    def message_counts(self) -> dict[int, int]:
        return dict(self._tally()[0])

    def time_range(self) -> tuple[int, int] | None:
        return self._tally()[1]

    def _tally(self) -> tuple[dict[int, int], tuple[int, int] | None]:
        """(connection id -> messages, (first, last) log time) of the rows that can be read."""
        if self._tallied is None:
            self._tallied = self._count()
        return self._tallied

    def _count(self) -> tuple[dict[int, int], tuple[int, int] | None]:
        counts = {connection.id: 0 for connection in self._connections}
        ends: list[int] = []
        if "messages" not in self._tables:
            return counts, None
        if not self._damaged:
            table = self._tables["messages"]
            try:
                rows = ids = 0
                for topic_id, count, first, last, bad, id_sum in self._db.execute(
                    _tally_query(table)
                ):
                    counts[integer_of(topic_id, "topic_id")] = integer_of(count, "count")
                    # MIN/MAX order NULL, then numbers, text and blobs: both ends are
                    # damage-free only when both are integers.
                    ends += [integer_of(first, "timestamp"), integer_of(last, "timestamp")]
                    if bad:
                        raise DamagedRow("a row's timestamp or data is of the wrong type")
                    rows, ids = rows + count, ids + integer_of(id_sum, "id")
                if self._db.execute(f"PRAGMA index_list({table})").fetchone() is not None:
                    listed, listed_ids, bad = self._db.execute(_index_query(table)).fetchone()
                    if (listed, listed_ids or 0, bad or 0) != (rows, ids, 0):
                        raise DamagedRow("the timestamp index does not list the table's rows")
                orphans = sorted(counts.keys() - {c.id for c in self._connections})
                if orphans:  # a topics row lost, or a topic_id damaged into another integer
                    self.damage.note(
                        None,
                        f"{sum(counts[i] for i in orphans)} message(s) of topic ids the topics "
                        f"table does not list ({', '.join(map(str, orphans))}): not read",
                    )
                return counts, (min(ends), max(ends)) if ends else None
            except READ_ERRORS as error:
                self._found_damage(error)
                counts, ends = dict.fromkeys(counts, 0), []
        # What messages() would deliver: rows of the topics (a row whose topic_id is damaged
        # can have a damaged id too, which stops a read in id order), with data (typeof(data),
        # as above: a row whose data cannot be read is no message).
        data = "CASE typeof(data) WHEN 'blob' THEN x'' END"
        topics = {connection.id for connection in self._connections}
        for _, topic_id, timestamp, _ in self._salvage(
            f"topic_id, timestamp, {data}", topics, None
        ):
            counts[topic_id] = counts.get(topic_id, 0) + 1
            ends = [min(ends[0], timestamp), max(ends[1], timestamp)] if ends else [timestamp] * 2
        # A read of some topics meets the same ranges, after the last id of its own rows.
        self._ranges_noted = True
        return counts, (ends[0], ends[1]) if ends else None

    def _found_damage(self, error: Exception) -> None:
        self._damaged = True
        self.damage.note(None, f"the database is damaged ({reason_of(error)})", key="database")

    def _damaged_row(self, table: str) -> None:
        self.damage.note(None, f"damaged rows of the {table} table skipped", key=f"row:{table}")

    def messages(
        self, connection_ids: set[int], start_ns: int | None, end_ns: int | None
    ) -> Iterator[RawMessage]:
        stored = self._stored_messages(connection_ids, start_ns, end_ns)
        return readable(stored, self._message_compression, self.damage)

    def _stored_messages(
        self, connection_ids: set[int], start_ns: int | None, end_ns: int | None
    ) -> Generator[RawMessage, None, None]:
        if not connection_ids or "messages" not in self._tables:
            return
        ids = ",".join(str(int(i)) for i in sorted(connection_ids))
        query = (
            f"SELECT rowid, topic_id, timestamp, data FROM {self._tables['messages']} "
            f"WHERE topic_id IN ({ids})"
        )
        parameters: list[int] = []
        if start_ns is not None:
            query += " AND timestamp >= ?"
            parameters.append(start_ns)
        if end_ns is not None:
            query += " AND timestamp < ?"
            parameters.append(end_ns)
        query += " ORDER BY timestamp, rowid"
        done = (-1, -1)  # (timestamp, id) of the last row delivered in time order
        if not self._damaged:
            try:
                # One row at a time: a batch of big messages would hold them all at once.
                for row_id, topic_id, timestamp, data in self._db.execute(query, parameters):
                    if not (
                        isinstance(timestamp, int)
                        and isinstance(topic_id, int)
                        and isinstance(data, bytes)
                    ):
                        # Sorted apart from the integers (NULL first, text and blobs last), so
                        # skipping it keeps the others in time order.
                        self.damage.note(None, "rows with missing fields skipped", key="fields")
                        continue
                    done = (timestamp, row_id)
                    yield topic_id, timestamp, data
                return
            except READ_ERRORS as error:
                self._found_damage(error)
        for row_id, topic_id, timestamp, data in self._salvage(
            "topic_id, timestamp, data", connection_ids, (start_ns, end_ns)
        ):
            if (timestamp, row_id) > done:
                yield topic_id, timestamp, data

    def _salvage(
        self,
        columns: str,
        connection_ids: set[int] | None,
        window: tuple[int | None, int | None] | None,
    ) -> Iterator[tuple[int, int, int, Any]]:
        return salvage_rows(
            self._db,
            self._tables["messages"],
            columns,
            row_filter(connection_ids, window),
            self.damage,
            note_ranges=not self._ranges_noted,
        )

    def close(self) -> None:
        self._database.close()
