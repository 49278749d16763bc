"""Open a rosbag2 ``.db3`` file read-only and immutable, however damaged, and find its tables.

The file is opened with ``mode=ro&immutable=1`` so reading a bag never leaves ``-wal``/``-shm``
files or changes it. A file cut short (fewer pages than its header declares) cannot be opened by
SQLite as it is: it is copied to a temporary file padded with zero pages (sparse, so cheap) and
read from there; cut inside its first page, which holds the schema, it has no table left to
read. A damaged schema (``sqlite_master``) is read with ``writable_schema`` and the rosbag2
tables are found by their columns, since the damaged byte may be a table's name. Only a file
whose schema is intact and has no ``topics``/``messages`` tables is not a bag (``BagError``);
anything else wrong is noted in the file's ``DamageLog``.
"""

from __future__ import annotations

import os
import shutil
import sqlite3
import tempfile
import urllib.parse
from pathlib import Path

from pyconnect.record.bag_damage import DamageLog
from pyconnect.record.bag_errors import BagError
from pyconnect.record.sqlite_salvage import READ_ERRORS, reason_of

__all__ = ["NOTHING_READABLE", "SqliteDatabase", "columns_of"]

NOTHING_READABLE = "no message can be read"
_HEADER = 100
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


def columns_of(db: sqlite3.Connection, table: str) -> list[str]:
    """The columns of ``table`` (quoted)."""
    return [str(row[1]) for row in db.execute(f"PRAGMA table_info({table})")]


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


class SqliteDatabase:
    """One ``.db3`` file opened read-only: ``db``, rosbag2's ``tables`` in it, and whether it is
    ``cut`` short; ``close`` also removes the padded copy of a file cut short."""

    def __init__(self, path: Path, damage: DamageLog) -> None:
        self.path = str(path)
        self.damage = damage
        self.cut = False
        self.tables: dict[str, str] = {}  # rosbag2's name -> the file's, quoted ({}: none found)
        self._copy: str | None = None
        source = path
        declared, size, page_size = _declared_size(path)
        schema_cut = declared > size and size < page_size  # page 1 holds the schema
        if declared > size:
            self.cut = True
            if schema_cut:
                told = "its header declares" if size >= _HEADER else "of a sqlite3 header"
                self.damage.note(
                    size,
                    f"the file is cut short inside its first page (the schema): {size} of the "
                    f"{declared} bytes {told}; {NOTHING_READABLE}",
                )
            else:
                self.damage.note(
                    size,
                    f"the file is cut short: {size} of the {declared} bytes its header declares",
                )
                source = self._padded_copy(path, size - size % page_size, declared)
        uri = f"file:{urllib.parse.quote(str(source.resolve()))}?mode=ro&immutable=1"
        try:
            self.db = sqlite3.connect(uri, uri=True, check_same_thread=False)
        except sqlite3.DatabaseError as error:
            self._remove_copy()
            raise BagError(f"{path}: not a sqlite3 bag ({error})") from None
        self.db.text_factory = self._text
        if schema_cut:
            return  # no table can be found
        try:
            self.tables = self._find_tables()
        except BagError:
            self.close()
            raise

    def _find_tables(self) -> dict[str, str]:
        """rosbag2's table name -> the file's (quoted); damage noted when the schema is damaged.

        ``BagError`` when the schema is intact and has no ``topics``/``messages`` tables.
        """
        try:
            names = {str(row[0]) for row in self.db.execute(_SCHEMA)}
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
            self.db.execute("PRAGMA writable_schema = ON")
            listed = [
                str(row[1])
                for row in self.db.execute("PRAGMA table_list")
                if row[0] == "main" and row[2] == "table"
            ]
            for name in map(_quoted, [*_ROLES, *listed]):
                columns = set(columns_of(self.db, name))
                for role, needed in _ROLES.items():
                    if needed <= columns:
                        found.setdefault(role, name)
        except READ_ERRORS as error:
            self.damage.note(
                None, f"the schema cannot be read ({reason_of(error)}): {NOTHING_READABLE}"
            )
            return {}
        lost = (
            ""
            if {"topics", "messages"} <= found.keys()
            else f"; it has no topics/messages table: {NOTHING_READABLE}"
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

    def close(self) -> None:
        self.db.close()
        self._remove_copy()
