"""Read rosbag2 sqlite3 (``.db3``) files of every schema version, read-only and immutable.

Schema versions differ in columns (``offered_qos_profiles`` appeared in Eloquent,
``type_description_hash`` and the ``message_definitions`` table in Iron); column lists are read
from the file rather than assumed. The file is opened with ``mode=ro&immutable=1`` so reading a
bag never leaves ``-wal``/``-shm`` files or changes it.

A file cut short (fewer pages than its header declares) cannot be opened by SQLite as it is: it
is copied to a temporary file padded with zero pages (sparse, so cheap) and read from there.
When pages of the ``messages`` table are unreadable, rows are read one batch at a time in id
order, stepping over the unreadable ranges; every readable row is delivered and the damage is
noted in ``damage`` (``pyconnect.record.bag_damage``), never raised. A flipped byte can also
leave a page SQLite still reads with wrong values in it: text that is not UTF-8 (read with
replacement characters), a NULL, text or blob where an integer belongs; such rows are damage
too (skipped and noted), never a ``UnicodeDecodeError`` or ``TypeError``.
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

__all__ = ["SqliteFile"]

_DEFINITION_ENCODINGS = ("ros2msg", "ros2idl")
_BATCH = 16  # rows per salvage query: a few big messages at most
_HEADER = 100


class _DamagedRow(ValueError):
    """A row SQLite reads whose values cannot be what rosbag2 wrote (a damaged page)."""


def _integer(value: object, what: str) -> int:
    """``value`` of an INTEGER column; a damaged row can hold NULL, text, a blob or a float."""
    if isinstance(value, int):
        return value
    raise _DamagedRow(f"a row's {what} is {type(value).__name__}, not an integer")


# What a damaged file can raise from a query: SQLite's errors; the message of one of them when
# it quotes damaged bytes (the sqlite3 module decodes it strictly); our own check of a row.
_ERRORS = (sqlite3.DatabaseError, UnicodeDecodeError, _DamagedRow)


def _reason(error: Exception) -> str:
    if isinstance(error, UnicodeDecodeError):  # SQLite's message, as far as it can be read
        return bytes(error.object).decode("utf-8", errors="replace")
    return str(error)


def _columns(db: sqlite3.Connection, table: str) -> list[str]:
    return [str(row[1]) for row in db.execute(f"PRAGMA table_info({table})")]


def _declared_size(path: Path) -> tuple[int, int, int]:
    """(bytes the header declares, bytes in the file, page size)."""
    with path.open("rb") as stream:
        head = stream.read(_HEADER)
        size = os.fstat(stream.fileno()).st_size
    if len(head) < _HEADER:
        return size, size, 1
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
        source = path
        declared, size, page_size = _declared_size(path)
        if declared > size:
            self._damaged = True
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
        try:
            tables = self._table_names()
        except _ERRORS as error:
            self._db.close()
            self._remove_copy()
            raise BagError(f"{path}: not a sqlite3 bag ({_reason(error)})") from None
        if not {"topics", "messages"} <= tables:
            self._db.close()
            self._remove_copy()
            raise BagError(f"{path}: not a rosbag2 sqlite3 file (no topics/messages tables)")
        try:
            self._connections = self._read_connections("message_definitions" in tables)
        except _ERRORS as error:
            self._connections = []
            self._found_damage(error)
            self.damage.note(None, "the topics table is unreadable: no message can be read")

    def _table_names(self) -> set[str]:
        query = "SELECT name FROM sqlite_master WHERE type = 'table'"
        try:
            return {str(row[0]) for row in self._db.execute(query)}
        except _ERRORS as error:
            # One damaged CREATE statement makes SQLite refuse every query on the file
            # ("malformed database schema"); with writable_schema it skips that table and reads
            # the others (the file stays read-only: it is opened so).
            self._db.execute("PRAGMA writable_schema = ON")
            tables = {str(row[0]) for row in self._db.execute(query)}
            self.damage.note(None, f"the schema is damaged ({_reason(error)})", key="schema")
            return tables

    def _text(self, raw: bytes) -> str:
        # SQLite hands TEXT over as stored; a flipped byte makes it invalid UTF-8, which the
        # default text factory raises on (UnicodeDecodeError) from any query that reads it.
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError:
            self.damage.note(None, "text that is not UTF-8 (read with U+FFFD)", key="utf-8")
            return raw.decode("utf-8", errors="replace")

    def _read_connections(self, has_definitions: bool) -> list[Connection]:
        columns = _columns(self._db, "topics")
        qos = "offered_qos_profiles" if "offered_qos_profiles" in columns else "''"
        type_hash = "type_description_hash" if "type_description_hash" in columns else "''"
        rows = self._db.execute(
            f"SELECT id, name, type, serialization_format, {qos}, {type_hash} FROM topics"
        ).fetchall()
        by_hash, by_type = self._read_definitions() if has_definitions else ({}, {})
        connections = []
        for topic_id, name, msg_type, serialization, offered_qos, stored_hash in rows:
            if not (
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

    def _read_definitions(self) -> tuple[dict[str, tuple[str, str]], dict[str, tuple[str, str]]]:
        """(definition by type hash, by type name); damage leaves the installed types to decode."""
        by_hash: dict[str, tuple[str, str]] = {}
        by_type: dict[str, tuple[str, str]] = {}
        try:
            for topic_type, encoding, text, definition_hash in self._db.execute(
                "SELECT topic_type, encoding, encoded_message_definition, type_description_hash "
                "FROM message_definitions"
            ):
                if not (isinstance(topic_type, str) and isinstance(text, str)):
                    self._damaged_row("message_definitions")
                elif encoding in _DEFINITION_ENCODINGS:
                    by_type[topic_type] = (text, encoding)
                    if isinstance(definition_hash, str) and definition_hash:
                        by_hash[definition_hash] = (text, encoding)
        except _ERRORS as error:
            self.damage.note(
                None,
                f"the message_definitions table is unreadable ({_reason(error)}); the installed "
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
        counts = {connection.id: 0 for connection in self._connections}
        if not self._damaged:
            try:
                for topic_id, count in self._db.execute(
                    "SELECT topic_id, COUNT(*) FROM messages GROUP BY topic_id"
                ):
                    counts[_integer(topic_id, "topic_id")] = _integer(count, "count")
                return counts
            except _ERRORS as error:
                self._found_damage(error)
                counts = dict.fromkeys(counts, 0)
        for _, topic_id, _, _ in self._salvage("topic_id, timestamp, x''", None, None):
            counts[int(topic_id)] = counts.get(int(topic_id), 0) + 1
        return counts

    def time_range(self) -> tuple[int, int] | None:
        if not self._damaged:
            try:
                first, last = self._db.execute(
                    "SELECT MIN(timestamp), MAX(timestamp) FROM messages"
                ).fetchone()
                if first is None and last is None:
                    return None
                # MIN/MAX order NULL, then numbers, text and blobs: both ends are damage-free
                # only when both are integers.
                return _integer(first, "timestamp"), _integer(last, "timestamp")
            except _ERRORS as error:
                self._found_damage(error)
        times = [t for _, _, t, _ in self._salvage("topic_id, timestamp, x''", None, None)]
        return (min(times), max(times)) if times else None

    def _found_damage(self, error: Exception) -> None:
        self._damaged = True
        self.damage.note(None, f"the database is damaged ({_reason(error)})", key="database")

    def _damaged_row(self, table: str) -> None:
        self.damage.note(None, f"damaged rows of the {table} table skipped", key=f"row:{table}")

    def messages(
        self, connection_ids: set[int], start_ns: int | None, end_ns: int | None
    ) -> Iterator[RawMessage]:
        if not connection_ids:
            return
        ids = ",".join(str(int(i)) for i in sorted(connection_ids))
        query = f"SELECT id, topic_id, timestamp, data FROM messages WHERE topic_id IN ({ids})"
        parameters: list[int] = []
        if start_ns is not None:
            query += " AND timestamp >= ?"
            parameters.append(start_ns)
        if end_ns is not None:
            query += " AND timestamp < ?"
            parameters.append(end_ns)
        query += " ORDER BY timestamp, id"
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
            except _ERRORS as error:
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
        """(id, then ``columns``) of rows in id order, stepping over ranges that cannot be read."""
        where = ""
        if connection_ids is not None:
            where += f" AND topic_id IN ({','.join(str(int(i)) for i in connection_ids)})"
        if window is not None and window[0] is not None:
            where += f" AND timestamp >= {int(window[0])}"
        if window is not None and window[1] is not None:
            where += f" AND timestamp < {int(window[1])}"
        query = f"SELECT id, {columns} FROM messages WHERE id > ?{where} ORDER BY id LIMIT ?"
        last = 0
        batch = _BATCH
        stepping = False  # the last query failed and we stepped on past it
        while True:
            try:
                rows = self._db.execute(query, (last, batch)).fetchall()
            except _ERRORS as error:
                if batch > 1:
                    batch = 1  # find the first unreadable row
                    continue
                if not stepping:  # one entry per unreadable range, not one per row stepped over
                    self.damage.note(
                        None,
                        f"rows of the messages table after id {last} are unreadable "
                        f"({_reason(error)})",
                        key=f"rows{last}",
                    )
                following = self._next_readable(last)
                if following is None:
                    return
                # step at least one row on: a filtered query may fail where an unfiltered does not
                last, batch, stepping = max(following - 1, last + 1), _BATCH, True
                continue
            stepping = False
            if not rows:
                return
            for row in rows:
                # a damaged b-tree can hand back rows out of order or with fields missing
                if not isinstance(row[0], int) or row[0] <= last:
                    self.damage.note(None, "the messages table is out of order", key="order")
                    break
                if (
                    isinstance(row[1], int)
                    and isinstance(row[2], int)
                    and isinstance(row[3], bytes)
                ):
                    yield row
                else:
                    self.damage.note(None, "rows with missing fields skipped", key="fields")
                last = row[0]
            else:
                continue
            last += 1

    def _next_readable(self, last: int) -> int | None:
        """The smallest id after ``last`` whose row can be read again (None: none)."""

        def readable_from(candidate: int) -> int | None:
            try:
                row = self._db.execute(
                    "SELECT id, length(data) FROM messages WHERE id >= ? ORDER BY id LIMIT 1",
                    (candidate,),
                ).fetchone()
            except _ERRORS:
                return -1
            return None if row is None else int(row[0])

        step = 1
        while step < 1 << 62:
            found = readable_from(last + step)
            if found is None:
                return None
            if found >= 0:
                low, high = last + step // 2 + 1, last + step
                while low < high:  # narrow down to the first readable id
                    middle = (low + high) // 2
                    if readable_from(middle) == -1:
                        low = middle + 1
                    else:
                        high = middle
                return readable_from(low) if readable_from(low) not in (None, -1) else found
            step *= 2
        return None

    def close(self) -> None:
        self._db.close()
        self._remove_copy()
