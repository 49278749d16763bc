"""``table_to_pandas``: integer and bool columns with nulls keep their exact values in pandas."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa

from pyconnect.record import open_bag
from pyconnect.record.mcap_recorder import McapRecorder
from pyconnect.record.table_pandas import table_to_pandas

OLD_COUNTER = "uint64 kept\n"
NEW_COUNTER = OLD_COUNTER + "uint64 big\nint8 small\nint32 mid\nbool flag\n"
BIG = 2**64 - 1  # float64 cannot hold it: 18446744073709551616.0


def two_counter_bags(tmp_path: Path) -> list[Path]:
    """/c as ``my_pkg/msg/Counter`` in two bags: the first stores a definition without the
    fields after ``kept``, the second (logged later) one with them."""
    bags = []
    for name, definition, data, start_ns in [
        ("old", OLD_COUNTER, struct.pack("<Q", BIG), 1_000),
        ("new", NEW_COUNTER, struct.pack("<QQb3xi?", BIG, BIG - 1, -128, -(2**31), True), 2_000),
    ]:
        with McapRecorder(tmp_path / name) as recorder:
            recorder.add_topic("/c", "my_pkg/msg/Counter", definition=definition)
            recorder.write("/c", b"\x00\x01\x00\x00" + data, log_time_ns=start_ns)
        bags.append(tmp_path / name)
    return bags


def test_integer_and_bool_columns_with_nulls_keep_exact_values(tmp_path: Path) -> None:
    with open_bag(two_counter_bags(tmp_path)) as bag:
        frame = table_to_pandas(bag.to_arrow("/c"))
    assert {name: str(dtype) for name, dtype in frame.dtypes.items()} == {
        "log_time_ns": "int64",
        "kept": "uint64",  # no null: the numpy dtype to_pandas gives, as before
        "big": "UInt64",
        "small": "Int8",
        "mid": "Int32",
        "flag": "boolean",
    }
    assert frame["kept"].tolist() == [BIG, BIG]
    assert frame["big"].tolist() == [pd.NA, BIG - 1]
    assert frame["small"].tolist() == [pd.NA, -128]
    assert frame["mid"].tolist() == [pd.NA, -(2**31)]
    assert frame["flag"].tolist() == [pd.NA, True]


def test_named_columns_are_nullable_without_a_null() -> None:
    table = pa.table({"a": pa.array([1, 2], pa.uint64()), "b": pa.array([1.5, None])})
    frame = table_to_pandas(table, nullable={"a", "b"})
    assert str(frame["a"].dtype) == "UInt64"
    assert frame["b"].dtype == np.float64  # floats keep NaN for null: exact already
    assert table_to_pandas(table)["a"].dtype == np.uint64


def test_to_pandas_of_an_open_bag_keeps_integers_with_nulls_exact(tmp_path: Path) -> None:
    with open_bag(two_counter_bags(tmp_path)) as bag:
        frame = bag.to_pandas("/c")
    assert str(frame["big"].dtype) == "UInt64"
    assert frame["big"].tolist() == [pd.NA, BIG - 1]
    assert frame["kept"].dtype == np.uint64
