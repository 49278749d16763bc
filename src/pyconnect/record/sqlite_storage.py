"""Read rosbag2 sqlite3 (``.db3``) files of every schema version, read-only and immutable.

Schema versions differ in columns (``offered_qos_profiles`` appeared in Eloquent,
``type_description_hash`` and the ``message_definitions`` table in Iron); column lists are read
from the file rather than assumed. The file is opened with ``mode=ro&immutable=1`` so reading a
bag never leaves ``-wal``/``-shm`` files or changes it.
"""

from __future__ import annotations

import sqlite3
import urllib.parse
from collections.abc import Iterator, Sequence
from pathlib import Path

from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_storage import Connection, RawMessage

__all__ = ["SqliteFile"]

_DEFINITION_ENCODINGS = ("ros2msg", "ros2idl")


def _columns(db: sqlite3.Connection, table: str) -> list[str]:
    return [row[1] for row in db.execute(f"PRAGMA table_info({table})")]


class SqliteFile:
    """One ``.db3`` file of a rosbag2 bag."""

    def __init__(self, path: Path) -> None:
        self.path = str(path)
        uri = f"file:{urllib.parse.quote(str(path.resolve()))}?mode=ro&immutable=1"
        try:
            self._db = sqlite3.connect(uri, uri=True, check_same_thread=False)
            tables = {row[0] for row in self._db.execute("SELECT name FROM sqlite_master")}
        except sqlite3.DatabaseError as error:
            raise BagError(f"{path}: not a sqlite3 bag ({error})") from None
        if not {"topics", "messages"} <= tables:
            self._db.close()
            raise BagError(f"{path}: not a rosbag2 sqlite3 file (no topics/messages tables)")
        self._connections = self._read_connections("message_definitions" in tables)

    def _read_connections(self, has_definitions: bool) -> list[Connection]:
        columns = _columns(self._db, "topics")
        qos = "offered_qos_profiles" if "offered_qos_profiles" in columns else "''"
        type_hash = "type_description_hash" if "type_description_hash" in columns else "''"
        rows = self._db.execute(
            f"SELECT id, name, type, serialization_format, {qos}, {type_hash} FROM topics"
        ).fetchall()
        by_hash: dict[str, tuple[str, str]] = {}
        by_type: dict[str, tuple[str, str]] = {}
        if has_definitions:
            for topic_type, encoding, text, definition_hash in self._db.execute(
                "SELECT topic_type, encoding, encoded_message_definition, type_description_hash "
                "FROM message_definitions"
            ):
                if encoding in _DEFINITION_ENCODINGS:
                    by_type[topic_type] = (text, encoding)
                    if definition_hash:
                        by_hash[definition_hash] = (text, encoding)
        connections = []
        for topic_id, name, msg_type, serialization, offered_qos, topic_hash in rows:
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
                    offered_qos_profiles=str(offered_qos or ""),
                )
            )
        return connections

    def connections(self) -> Sequence[Connection]:
        return self._connections

    def message_counts(self) -> dict[int, int]:
        counts = {connection.id: 0 for connection in self._connections}
        for topic_id, count in self._db.execute(
            "SELECT topic_id, COUNT(*) FROM messages GROUP BY topic_id"
        ):
            counts[int(topic_id)] = int(count)
        return counts

    def time_range(self) -> tuple[int, int] | None:
        first, last = self._db.execute(
            "SELECT MIN(timestamp), MAX(timestamp) FROM messages"
        ).fetchone()
        return None if first is None else (int(first), int(last))

    def messages(
        self, connection_ids: set[int], start_ns: int | None, end_ns: int | None
    ) -> Iterator[RawMessage]:
        if not connection_ids:
            return
        ids = ",".join(str(int(i)) for i in sorted(connection_ids))
        query = f"SELECT topic_id, timestamp, data FROM messages WHERE topic_id IN ({ids})"
        parameters: list[int] = []
        if start_ns is not None:
            query += " AND timestamp >= ?"
            parameters.append(start_ns)
        if end_ns is not None:
            query += " AND timestamp < ?"
            parameters.append(end_ns)
        query += " ORDER BY timestamp, id"
        yield from self._db.execute(query, parameters)

    def close(self) -> None:
        self._db.close()
