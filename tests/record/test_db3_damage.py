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


def _schema_sql(old: str, new: str) -> Callable[[sqlite3.Connection], None]:
    """Damage: ``old`` replaced by ``new`` in the CREATE statements of sqlite_master."""

    def damage(db: sqlite3.Connection) -> None:
        db.commit()
        db.execute("PRAGMA writable_schema = ON")
        db.execute("UPDATE sqlite_master SET sql = replace(sql, ?, ?)", (old, new))

    return damage


def _orphan_message(db: sqlite3.Connection) -> None:
    db.execute("INSERT INTO messages VALUES (NULL, 9, 105, ?)", (_hello(5),))


def _schema_name(db: sqlite3.Connection) -> None:
    db.commit()
    db.execute("PRAGMA writable_schema = ON")
    db.execute("UPDATE sqlite_master SET name = 'topicz' WHERE name = 'topics'")


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
    "a topic_id no topic has": (
        _orphan_message,
        "1 message(s) of topic ids the topics table does not list (9): not read",
    ),
    # SQLite reads every table with writable_schema; open_bag refused the bag as not a rosbag2
    # file, its tables missing from sqlite_master's name column.
    "a table's name in sqlite_master": (
        _schema_name,
        "the schema is damaged (malformed database schema (topicz))",
    ),
    "a table's name in its CREATE statement": (
        _schema_sql("TABLE messages", "TABLE mossages"),
        "the schema is damaged (malformed database schema (messages))",
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
    assert f"{path}: {expected}" in [str(d) for d in info.damage]
    # the messages that can be read: the damaged row is none (info counted text data as one)
    assert next(t for t in info.topics if t.name == "/chatter").message_count == 5
    assert main(["bag", "info", str(path)]) == 1  # printed, damage reported, no raise
    assert "  /chatter  std_msgs/msg/String  " in capsys.readouterr().out


# Byte flips found by fuzzing the shared bags (/tmp/review_record/bug_db3_flip_raises.py).
SHARED_SQLITE = BAGS / "rosbags_rs/test_bag_sqlite3/test_bag_sqlite3.db3"
SHARED_TALKER = BAGS / "ros2_rosbag2_jazzy/rosbag2_py/test/resources/sqlite3/talker/talker.db3"
SHARED_WBAG = BAGS / "ros2_rosbag2_jazzy/rosbag2_py/test/resources/sqlite3/wbag/wbag_1.db3"
SHARED_CDR = BAGS / "ros2_rosbag2_jazzy/rosbag2_tests/resources/sqlite3/cdr_test/cdr_test_0.db3"
FLIPS = {
    "a byte of sqlite_master": (SHARED_SQLITE, 3451, 240, "the schema is damaged"),
    "a byte of the messages table": (SHARED_SQLITE, 122548, 212, "the database is damaged"),
    "a byte of a timestamp": (SHARED_TALKER, 12303, 203, "the database is damaged"),
    # Found by fuzzing this fix: info counted what echo could not read, said nothing, or raised.
    "a byte of a topic's id": (SHARED_SQLITE, 48243, 44, "damaged rows of the topics table"),
    "a byte of a message's id": (SHARED_WBAG, 28101, 255, "the database is damaged"),
    "a byte of INTEGER PRIMARY KEY": (SHARED_CDR, 3312, 165, None),  # rowid reads it still
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
    read: dict[str, int] = {}
    with open_bag(path, raw=True) as bag:
        for message in bag:
            read[message.topic] = read.get(message.topic, 0) + 1
        found = [str(d) for d in bag.damage]
    info = bag_info(path)
    if expected is None:
        assert (found, info.damage, sum(read.values())) == ([], (), whole)
    else:
        assert any(d.startswith(f"{path}: {expected}") for d in found), found
        assert any(d.startswith(f"{path}: {expected}") for d in map(str, info.damage))
    assert whole - 10 <= sum(read.values()) <= whole
    assert {t.name: t.message_count for t in info.topics if t.message_count} == read


def wbag_with_a_broken_messages_page(tmp_path: Path) -> Path:
    """A copy of rosbag2's wbag_1.db3 with four bits flipped: one page of its messages table
    cannot be read (a row of topic DDD is lost with it)."""
    source = BAGS / "ros2_rosbag2_jazzy/rosbag2_py/test/resources/sqlite3/wbag/wbag_1.db3"
    require_sample_bags(source, source.is_file())
    data = bytearray(source.read_bytes())
    for offset, bit in [(9494, 2), (47931, 1), (66510, 8), (85319, 1)]:
        data[offset] ^= bit
    bag = tmp_path / "wbag_1.db3"
    bag.write_bytes(bytes(data))
    return bag


def test_a_damaged_messages_page_met_by_a_table_is_the_bags_damage(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Tables read each topic with a reader of their own: the damage it meets (here a page of
    # the messages table) was dropped with it, and a Parquet export lost a row with exit 0.
    bag = wbag_with_a_broken_messages_page(tmp_path)
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


def test_a_flipped_byte_of_a_tables_name_in_sqlite_master(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Found by fuzzing: "topics" became "topic\xaa" in sqlite_master's name column. SQLite reads
    # every table (with writable_schema); open_bag refused the bag as not a rosbag2 file, exit 2.
    source = BAGS / (
        "ros2_rosbag2_jazzy/rosbag2_py/test/resources/sqlite3/reindex_test_bags/multiple_files/"
        "multiple_files_2.db3"
    )
    require_sample_bags(source, source.is_file())
    data = bytearray(source.read_bytes())
    assert data[3932:3938] == b"topics"
    data[3937] = 0xAA
    bag = tmp_path / "multiple_files_2.db3"
    bag.write_bytes(bytes(data))
    with open_bag(source, raw=True) as intact, open_bag(bag, raw=True) as damaged:
        assert list(damaged) == list(intact)
        expected = [f"{bag}: the schema is damaged (malformed database schema (topic\ufffd))"]
        assert [str(d) for d in damaged.damage] == expected
    assert main(["bag", "echo", str(bag)]) == 1
    assert f"damaged bag: {expected[0]}; 529 message(s) read" in capsys.readouterr().err


UNREADABLE_SCHEMAS = {  # offset, bytes there: what is found
    "the page size": (16, b"\x00\x03", "the schema cannot be read (file is not a database)"),
    "page 1's b-tree header": (
        100,
        bytes(8),
        "the schema is damaged (database disk image is malformed); it has no topics/messages table",
    ),
}


@pytest.mark.parametrize("case", list(UNREADABLE_SCHEMAS))
def test_a_schema_that_cannot_be_read_is_damage_an_intact_one_without_tables_no_bag(
    case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    offset, damage, expected = UNREADABLE_SCHEMAS[case]
    data = bytearray(write_jazzy_db3(tmp_path / "bag.db3", lambda db: None).read_bytes())
    data[offset : offset + len(damage)] = damage
    damaged = tmp_path / "damaged.db3"
    damaged.write_bytes(bytes(data))
    with open_bag(damaged) as bag:  # a sqlite3 file (its magic): damage, not "not a bag"
        assert list(bag) == []
        assert [str(d) for d in bag.damage] == [f"{damaged}: {expected}: no message can be read"]
    assert main(["bag", "info", str(damaged)]) == 1
    other = tmp_path / "other.db3"
    db = sqlite3.connect(other)
    db.execute("CREATE TABLE notes(id INTEGER PRIMARY KEY, text TEXT)")
    db.commit()
    db.close()
    capsys.readouterr()
    assert main(["bag", "info", str(other)]) == 2
    assert capsys.readouterr().err == (
        f"pyconnect: error: {other}: not a rosbag2 sqlite3 file (no topics/messages tables)\n"
    )


def test_info_counts_the_messages_that_can_be_read(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # A row of the messages table whose record is damaged past its topic_id: info counted it (a
    # count reads less than a message), said nothing and exited 0; echo cannot read it.
    bag = wbag_with_a_broken_messages_page(tmp_path)
    with open_bag(bag, raw=True) as reader:
        read: dict[str, int] = {}
        for message in reader:
            read[message.topic] = read.get(message.topic, 0) + 1
        times = [reader.info.start_ns, reader.info.end_ns]
    info = bag_info(bag)
    assert {topic.name: topic.message_count for topic in info.topics} == read
    assert info.message_count == 1239  # of 1240: row 507 is unreadable
    assert [info.start_ns, info.end_ns] == times
    assert [str(d) for d in info.damage] == [
        f"{bag}: the database is damaged (database disk image is malformed)",
        f"{bag}: rows of the messages table after id 506 are unreadable "
        "(database disk image is malformed)",
    ]
    assert main(["bag", "info", str(bag)]) == 1
    captured = capsys.readouterr()
    assert "messages:  1239\n" in captured.out
    assert captured.err.startswith(f"pyconnect: {bag}: damaged bag: ")
