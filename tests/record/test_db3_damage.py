"""``.db3`` files whose pages SQLite still reads, with wrong values in them: damage, not errors.

A flipped byte can leave text that is not UTF-8, a NULL, text or blob in an INTEGER column, or a
CREATE statement SQLite cannot parse. ``open_bag`` and ``bag info`` list the damage and deliver
every intact message; they raised UnicodeDecodeError, TypeError and ValueError.
"""

from __future__ import annotations

import sqlite3
from collections.abc import Callable
from pathlib import Path

import pytest
from rclpy.serialization import serialize_message
from std_msgs.msg import String

from pyconnect.cli import main
from pyconnect.record.bag_reader import bag_info, open_bag
from tests.conftest import require_sample_bags
from tests.record.bag_samples import BAGS

STRING_DEFINITION = "string data\n"


def _hello(i: int) -> bytes:
    return bytes(serialize_message(String(data=f"hello {i}")))


def write_jazzy_db3(path: Path, damage: Callable[[sqlite3.Connection], None]) -> Path:
    """A db3 with the tables of a Jazzy rosbag2 (NOT NULL left out, so damage can be stored):
    /chatter with hello 0..4 at 100..104, then ``damage`` applied."""
    db = sqlite3.connect(path)
    db.executescript(
        "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT, type TEXT, "
        "serialization_format TEXT, offered_qos_profiles TEXT, type_description_hash TEXT);"
        "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER, timestamp INTEGER, "
        "data BLOB);"
        "CREATE TABLE message_definitions(id INTEGER PRIMARY KEY, topic_type TEXT, "
        "encoding TEXT, encoded_message_definition TEXT, type_description_hash TEXT);"
    )
    db.execute("INSERT INTO topics VALUES (1, '/chatter', 'std_msgs/msg/String', 'cdr', '', '')")
    db.execute(
        "INSERT INTO message_definitions VALUES (1, 'std_msgs/msg/String', 'ros2msg', ?, '')",
        (STRING_DEFINITION,),
    )
    for i in range(5):
        db.execute("INSERT INTO messages VALUES (NULL, 1, ?, ?)", (100 + i, _hello(i)))
    damage(db)
    db.commit()
    db.close()
    return path


def _bad_utf8_topic(db: sqlite3.Connection) -> None:
    db.execute(
        "INSERT INTO topics VALUES (2, CAST(x'2f636861f07474' AS TEXT), 'std_msgs/msg/String', "
        "'cdr', '', '')"
    )


def _null_topic_id(db: sqlite3.Connection) -> None:
    db.execute("INSERT INTO messages VALUES (NULL, NULL, 105, ?)", (_hello(5),))


def _blob_timestamp(db: sqlite3.Connection) -> None:
    db.execute("INSERT INTO messages VALUES (NULL, 1, x'', ?)", (_hello(5),))


def _text_data(db: sqlite3.Connection) -> None:
    db.execute("INSERT INTO messages VALUES (NULL, 1, 105, 'not a blob')")


def _malformed_schema(db: sqlite3.Connection) -> None:
    db.commit()
    db.execute("PRAGMA writable_schema = ON")
    broken = (  # one flipped byte: 0xf0 after NULL, as in a shared bag found by fuzzing
        b"CREATE TABLE message_definitions(id INTEGER PRIMARY KEY, topic_type TEXT NOT NULL\xf0 "
        b"encoding TEXT, encoded_message_definition TEXT, type_description_hash TEXT)"
    )
    db.execute(
        "UPDATE sqlite_master SET sql = CAST(? AS TEXT) WHERE name = 'message_definitions'",
        (broken,),
    )


CASES = {
    "a topic name that is not UTF-8": (
        _bad_utf8_topic,
        "text that is not UTF-8 (read with U+FFFD)",
    ),
    "a NULL topic_id": (
        _null_topic_id,
        "the database is damaged (a row's topic_id is NoneType, not an integer)",
    ),
    "a blob timestamp": (
        _blob_timestamp,
        "the database is damaged (a row's timestamp is bytes, not an integer)",
    ),
    "text data": (_text_data, "rows with missing fields skipped"),  # seen when read only
    "a CREATE statement SQLite cannot parse": (
        _malformed_schema,
        "the schema is damaged (malformed database schema (message_definitions) - near "
        '"NULL\ufffd": syntax error)',
    ),
}


@pytest.mark.parametrize("case", list(CASES))
def test_damaged_values_are_listed_and_intact_messages_delivered(
    case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    damage, expected = CASES[case]
    path = write_jazzy_db3(tmp_path / "damaged.db3", damage)
    with open_bag(path) as bag:
        chatter = [(m.log_time_ns, m.value) for m in bag if m.topic == "/chatter"]
        found = [str(d) for d in bag.damage]
    assert chatter == [(100 + i, f"hello {i}") for i in range(5)]
    assert f"{path}: {expected}" in found, found
    assert [str(d) for d in bag.damage] == found  # still there once the files are closed
    info = bag_info(path)
    seen = case != "text data"  # info reads counts and times, not the data
    assert (f"{path}: {expected}" in [str(d) for d in info.damage]) == seen
    assert next(t for t in info.topics if t.name == "/chatter").message_count >= 5
    assert main(["bag", "info", str(path)]) == int(seen)  # printed, damage reported, no raise
    assert "  /chatter  std_msgs/msg/String  " in capsys.readouterr().out


# Byte flips found by fuzzing the shared bags (/tmp/review_record/bug_db3_flip_raises.py).
SHARED_SQLITE = BAGS / "rosbags_rs/test_bag_sqlite3/test_bag_sqlite3.db3"
SHARED_TALKER = BAGS / "ros2_rosbag2_jazzy/rosbag2_py/test/resources/sqlite3/talker/talker.db3"
FLIPS = {
    "a byte of sqlite_master": (SHARED_SQLITE, 3451, 240, "the schema is damaged"),
    "a byte of the messages table": (SHARED_SQLITE, 122548, 212, "the database is damaged"),
    "a byte of a timestamp": (SHARED_TALKER, 12303, 203, "the database is damaged"),
}


@pytest.mark.parametrize("case", list(FLIPS))
def test_flipped_bytes_of_shared_bags(case: str, tmp_path: Path) -> None:
    source, offset, value, expected = FLIPS[case]
    require_sample_bags(source, source.exists())
    with open_bag(source, raw=True) as intact:
        whole = len(list(intact))
    data = bytearray(source.read_bytes())
    data[offset] = value
    path = tmp_path / "flipped.db3"
    path.write_bytes(bytes(data))
    with open_bag(path, raw=True) as bag:
        read = len(list(bag))
        found = [str(d) for d in bag.damage]
    assert any(d.startswith(f"{path}: {expected}") for d in found), found
    assert whole - 10 <= read <= whole
    assert any(d.startswith(f"{path}: {expected}") for d in map(str, bag_info(path).damage))


def test_a_damaged_messages_page_met_by_a_table_is_the_bags_damage(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Tables read each topic with a reader of their own: the damage it meets (here a page of
    # the messages table) was dropped with it, and a Parquet export lost a row with exit 0.
    source = BAGS / "ros2_rosbag2_jazzy/rosbag2_py/test/resources/sqlite3/wbag/wbag_1.db3"
    require_sample_bags(source, source.is_file())
    data = bytearray(source.read_bytes())
    for offset, bit in [(9494, 2), (47931, 1), (66510, 8), (85319, 1)]:  # four flipped bits
        data[offset] ^= bit
    bag = tmp_path / "wbag_1.db3"
    bag.write_bytes(bytes(data))
    with open_bag(bag) as reader:
        read = sum(1 for message in reader if message.topic == "DDD")
    with open_bag(bag) as reader:
        table = reader.to_arrow("DDD")
        unreadable = [d for d in reader.damage if "rows of the messages table" in str(d)]
    assert table.num_rows == read
    assert len(unreadable) == 1  # one entry for the range, not one per row stepped over
    argv = ["bag", "export", str(bag), "--format", "parquet", "--to", str(tmp_path / "pq")]
    assert main(argv) == 1
    assert "damaged bag" in capsys.readouterr().err
