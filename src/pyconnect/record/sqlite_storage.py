"""Read rosbag2 sqlite3 (``.db3``) files of every schema version, read-only and immutable.

Schema versions differ in columns (``offered_qos_profiles`` appeared in Eloquent,
``type_description_hash`` and the ``message_definitions`` table in Iron); column lists are read
from the file rather than assumed. The file is opened with ``mode=ro&immutable=1`` so reading a
bag never leaves ``-wal``/``-shm`` files or changes it.

A file cut short (fewer pages than its header declares) cannot be opened by SQLite as it is: it
is copied to a temporary file padded with zero pages (sparse, so cheap) and read from there; cut
inside its first page, which holds the schema, it has no table left to read. A damaged schema
(``sqlite_master``) is read with ``writable_schema`` and the rosbag2 tables are found by their
columns, since the damaged byte may be a table's name. Only a file whose schema is intact and has
no ``topics``/``messages`` tables is not a bag (``BagError``); anything else wrong is damage.
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

import os
import shutil
import sqlite3
import tempfile
import urllib.parse
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

from pyconnect.record.bag_damage import DamageLog
from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_storage import Connection, RawMessage
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
_HEADER = 100
_NOTHING = "no message can be read"
_SCHEMA = "SELECT name FROM sqlite_master WHERE type = 'table'"
# rosbag2's tables, by the columns that tell them when a damaged byte is a name. Queries read
# ``id`` (INTEGER PRIMARY KEY) as rowid, which a damaged type in the CREATE statement leaves.
_ROLES = {
    "topics": {"id", "name", "type", "serialization_format"},
    "messages": {"id", "topic_id", "timestamp", "data"},
    "message_definitions": {"topic_type", "encoding", "encoded_message_definition"},
}


def _quoted(name: str) -> str:
    return '"' + name.replace('"', '""') + '"'


def _columns(db: sqlite3.Connection, table: str) -> list[str]:
    """The columns of ``table`` (quoted)."""
    return [str(row[1]) for row in db.execute(f"PRAGMA table_info({table})")]


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


def _declared_size(path: Path) -> tuple[int, int, int]:
    """(bytes the header declares, bytes in the file, page size)."""
    with path.open("rb") as stream:
        head = stream.read(_HEADER)
        size = os.fstat(stream.fileno()).st_size
    if len(head) < _HEADER:  # the magic and less: a cut inside the first page
        return _HEADER, size, _HEADER
    page_size = int.from_bytes(head[16:18], "big")
    page_size = 65536 if page_size == 1 else page_size
    pages = int.from_bytes(head[28:32], "big")
    return page_size * pages, size, max(page_size, 1)


class SqliteFile:
    """One ``.db3`` file of a rosbag2 bag."""

    def __init__(self, path: Path) -> None:
        self.path = str(path)
        self.damage = DamageLog(self.path)
        self.promised: int | None = None
        self._copy: str | None = None
        self._damaged = False
        self._connections: list[Connection] = []
        self._tables: dict[str, str] = {}  # rosbag2's name -> the file's, quoted ({}: none read)
        self._tallied: tuple[dict[int, int], tuple[int, int] | None] | None = None
        self._ranges_noted = False  # every unreadable range of the messages table is noted
        source = path
        declared, size, page_size = _declared_size(path)
        schema_cut = declared > size and size < page_size  # page 1 holds the schema
        if declared > size:
            self._damaged = True
            if schema_cut:
                told = "its header declares" if size >= _HEADER else "of a sqlite3 header"
                self.damage.note(
                    size,
                    f"the file is cut short inside its first page (the schema): {size} of the "
                    f"{declared} bytes {told}; {_NOTHING}",
                )
            else:
                self.damage.note(
                    size,
                    f"the file is cut short: {size} of the {declared} bytes its header declares",
                )
                source = self._padded_copy(path, size - size % page_size, declared)
        uri = f"file:{urllib.parse.quote(str(source.resolve()))}?mode=ro&immutable=1"
        try:
            self._db = sqlite3.connect(uri, uri=True, check_same_thread=False)
        except sqlite3.DatabaseError as error:
            self._remove_copy()
            raise BagError(f"{path}: not a sqlite3 bag ({error})") from None
        self._db.text_factory = self._text
        if schema_cut:
            return  # no table can be found
        try:
            tables = self._find_tables()
        except BagError:
            self.close()
            raise
        if not {"topics", "messages"} <= tables.keys():
            return  # the damage says why
        self._tables = tables
        try:
            self._connections = self._read_connections()
        except READ_ERRORS as error:
            self._found_damage(error)
            self.damage.note(None, f"the topics table is unreadable: {_NOTHING}")

    def _find_tables(self) -> dict[str, str]:
        """rosbag2's table name -> the file's (quoted); damage noted when the schema is damaged.

        ``BagError`` when the schema is intact and has no ``topics``/``messages`` tables.
        """
        try:
            names = {str(row[0]) for row in self._db.execute(_SCHEMA)}
        except READ_ERRORS as error:
            reason = reason_of(error)
        else:
            if not {"topics", "messages"} <= names:
                raise BagError(
                    f"{self.path}: not a rosbag2 sqlite3 file (no topics/messages tables)"
                )
            return {role: _quoted(role) for role in _ROLES if role in names}
        # One damaged CREATE statement or name makes SQLite refuse every query on the file
        # ("malformed database schema"); with writable_schema it skips what it cannot parse and
        # reads the rest (the file stays read-only: it is opened so). A table is named by its
        # CREATE statement, not by sqlite_master's name column, which may be the damaged byte.
        found: dict[str, str] = {}
        try:
            self._db.execute("PRAGMA writable_schema = ON")
            listed = [
                str(row[1])
                for row in self._db.execute("PRAGMA table_list")
                if row[0] == "main" and row[2] == "table"
            ]
            for name in map(_quoted, [*_ROLES, *listed]):
                columns = set(_columns(self._db, name))
                for role, needed in _ROLES.items():
                    if needed <= columns:
                        found.setdefault(role, name)
        except READ_ERRORS as error:
            self.damage.note(None, f"the schema cannot be read ({reason_of(error)}): {_NOTHING}")
            return {}
        lost = (
            ""
            if {"topics", "messages"} <= found.keys()
            else f"; it has no topics/messages table: {_NOTHING}"
        )
        self.damage.note(None, f"the schema is damaged ({reason}){lost}", key="schema")
        return found

    def _text(self, raw: bytes) -> str:
        # SQLite hands TEXT over as stored; a flipped byte makes it invalid UTF-8, which the
        # default text factory raises on (UnicodeDecodeError) from any query that reads it.
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError:
            self.damage.note(None, "text that is not UTF-8 (read with U+FFFD)", key="utf-8")
            return raw.decode("utf-8", errors="replace")

    def _read_connections(self) -> list[Connection]:
        columns = _columns(self._db, self._tables["topics"])
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

    def _padded_copy(self, path: Path, whole_pages: int, declared: int) -> Path:
        handle, name = tempfile.mkstemp(prefix="pyconnect-salvage-", suffix=".db3")
        os.close(handle)
        self._copy = name
        shutil.copyfile(path, name)
        # The page cut in two goes (its cells would read as altered data); the missing pages
        # become zero pages, which SQLite reports as corrupt when it meets them.
        os.truncate(name, whole_pages)
        os.truncate(name, declared)
        return Path(name)

    def _remove_copy(self) -> None:
        if self._copy is not None:
            os.unlink(self._copy)
            self._copy = None

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
        self._db.close()
        self._remove_copy()
