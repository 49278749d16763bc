"""Reading the rows of a damaged ``.db3`` messages table that can still be read.

SQLite stops a query at the first page it cannot read. ``salvage_rows`` reads the table one
batch at a time in id order instead, and when a batch fails narrows it down to the first
unreadable row, then looks for the next row that can be read again (doubling steps, then a
binary search), so every readable row is delivered and each unreadable range is noted once in
the bag's ``DamageLog``. Rows SQLite reads but whose values cannot be what rosbag2 wrote (a
NULL, text or blob where an integer belongs) are skipped and noted too.
"""

from __future__ import annotations

import sqlite3
from collections.abc import Iterator
from typing import Any

from pyconnect.record.bag_damage import DamageLog

__all__ = [
    "READ_ERRORS",
    "DamagedRow",
    "integer_of",
    "reason_of",
    "row_filter",
    "salvage_rows",
]

_BATCH = 16  # rows per salvage query: a few big messages at most


class DamagedRow(ValueError):
    """A row SQLite reads whose values cannot be what rosbag2 wrote (a damaged page)."""


def integer_of(value: object, what: str) -> int:
    """``value`` of an INTEGER column; a damaged row can hold NULL, text, a blob or a float."""
    if isinstance(value, int):
        return value
    raise DamagedRow(f"a row's {what} is {type(value).__name__}, not an integer")


# What a damaged file can raise from a query: SQLite's errors; the message of one of them when
# it quotes damaged bytes (the sqlite3 module decodes it strictly); our own check of a row.
READ_ERRORS = (sqlite3.DatabaseError, UnicodeDecodeError, DamagedRow)


def reason_of(error: Exception) -> str:
    """An error's text for a damage entry."""
    if isinstance(error, UnicodeDecodeError):  # SQLite's message, as far as it can be read
        return bytes(error.object).decode("utf-8", errors="replace")
    return str(error)


def row_filter(
    connection_ids: set[int] | None, window: tuple[int | None, int | None] | None
) -> str:
    """The ``AND ...`` conditions of a salvage query: the topics and the time window."""
    where = ""
    if connection_ids is not None:
        where += f" AND topic_id IN ({','.join(str(int(i)) for i in connection_ids)})"
    if window is not None and window[0] is not None:
        where += f" AND timestamp >= {int(window[0])}"
    if window is not None and window[1] is not None:
        where += f" AND timestamp < {int(window[1])}"
    return where


def salvage_rows(
    db: sqlite3.Connection,
    table: str,
    columns: str,
    where: str,
    damage: DamageLog,
    *,
    note_ranges: bool,
) -> Iterator[tuple[int, int, int, Any]]:
    """(id, then ``columns``: topic id, timestamp, data) of the rows of ``table`` (quoted) in
    id order that match ``where``, stepping over ranges that cannot be read; unreadable
    ranges are noted in ``damage`` when ``note_ranges`` (a later read meets the same ones)."""
    query = f"SELECT rowid, {columns} FROM {table} WHERE rowid > ?{where} ORDER BY rowid LIMIT ?"
    last = 0
    batch = _BATCH
    stepping = False  # the last query failed and we stepped on past it
    while True:
        try:
            rows = db.execute(query, (last, batch)).fetchall()
        except READ_ERRORS as error:
            if batch > 1:
                batch = 1  # find the first unreadable row
                continue
            # one entry per unreadable range, not one per row stepped over
            if note_ranges and not stepping:
                damage.note(
                    None,
                    f"rows of the messages table after id {last} are unreadable "
                    f"({reason_of(error)})",
                    key=f"rows{last}",
                )
            following = next_readable(db, table, last)
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
                damage.note(None, "the messages table is out of order", key="order")
                break
            if isinstance(row[1], int) and isinstance(row[2], int) and isinstance(row[3], bytes):
                yield row
            else:
                damage.note(None, "rows with missing fields skipped", key="fields")
            last = row[0]
        else:
            continue
        last += 1


def next_readable(db: sqlite3.Connection, table: str, last: int) -> int | None:
    """The smallest id after ``last`` whose row can be read again (None: none)."""

    def readable_from(candidate: int) -> int | None:
        try:
            row = db.execute(
                f"SELECT rowid, length(data) FROM {table} WHERE rowid >= ? ORDER BY rowid LIMIT 1",
                (candidate,),
            ).fetchone()
        except READ_ERRORS:
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
