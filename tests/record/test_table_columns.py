"""``pyconnect.record.table_columns``: the Arrow type of each field, top level or nested."""

from __future__ import annotations

from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from action_msgs.msg import GoalStatus, GoalStatusArray
from test_msgs.msg import Arrays, MultiNested

from pyconnect.record import open_bag
from pyconnect.record.parquet_export import export_parquet
from tests.record.table_bags import write_bag

UUIDS = [bytes(range(16)), bytes([255] * 16)]


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    status = GoalStatusArray()
    status.status_list = [GoalStatus(), GoalStatus()]
    for goal, uuid in zip(status.status_list, UUIDS, strict=True):
        goal.goal_info.goal_id.uuid = list(uuid)
    multi = MultiNested()
    arrays = Arrays()
    arrays.byte_values = [b"\x01", b"\xff", b"\x00"]
    multi.array_of_arrays = [arrays, Arrays(), Arrays()]
    multi.unbounded_sequence_of_arrays = [arrays]
    messages = [("/status", 1, status), ("/multi", 2, multi)]
    return write_bag(tmp_path_factory.mktemp("columns") / "bag", messages)


def _uuid_type(schema: pa.Schema) -> pa.DataType:
    goal_info = schema.field("status_list").type.value_type.field("goal_info").type
    return goal_info.field("goal_id").type.field("uuid").type


def _byte_values_type(schema: pa.Schema, name: str) -> pa.DataType:
    return schema.field(name).type.value_type.field("byte_values").type


def test_a_nested_fixed_byte_array_keeps_its_size(bag: Path) -> None:
    # It was `binary` while the same uint8[N] at the top level is fixed_size_binary(N).
    with open_bag(bag) as reader:
        status = reader.to_arrow("/status")
        multi = reader.to_arrow("/multi")
        frame = reader.to_pandas("/status")
        polars_frame = reader.to_polars("/multi")
    assert _uuid_type(status.schema) == pa.binary(16)
    goals = status.column("status_list").to_pylist()[0]
    assert [goal["goal_info"]["goal_id"]["uuid"] for goal in goals] == UUIDS
    assert _byte_values_type(multi.schema, "array_of_arrays") == pa.binary(3)
    fixed = [item["byte_values"] for item in multi.column("array_of_arrays").to_pylist()[0]]
    assert fixed == [b"\x01\xff\x00", bytes(3), bytes(3)]
    assert _byte_values_type(multi.schema, "unbounded_sequence_of_arrays") == pa.binary(3)
    # A sequence of bytes (byte[], byte[<=N]) stays variable, nested or not.
    assert _byte_values_type(multi.schema, "array_of_unbounded_sequences") == pa.binary()
    assert _byte_values_type(multi.schema, "array_of_bounded_sequences") == pa.binary()
    assert frame["status_list"][0][1]["goal_info"]["goal_id"]["uuid"] == UUIDS[1]
    assert polars_frame["array_of_arrays"].to_list()[0][0]["byte_values"] == b"\x01\xff\x00"


def test_parquet_export_keeps_a_nested_fixed_byte_array(bag: Path, tmp_path: Path) -> None:
    result = export_parquet(bag, tmp_path / "out")
    assert result.errors == []
    status = pq.read_table(result.files["/status"][0])
    assert _uuid_type(status.schema) == pa.binary(16)
    goals = status.column("status_list").to_pylist()[0]
    assert [goal["goal_info"]["goal_id"]["uuid"] for goal in goals] == UUIDS
    multi = pq.read_table(result.files["/multi"][0])
    assert _byte_values_type(multi.schema, "array_of_arrays") == pa.binary(3)


def test_a_column_named_like_the_log_time_is_refused() -> None:
    from pyconnect.record.table_columns import Column, schema_of

    with pytest.raises(ValueError) as raised:
        schema_of([Column(("log_time_ns",), pa.int64(), "scalar")], topic="/ev", msg_type="p/T")
    assert str(raised.value) == (
        "columns: /ev: a column named log_time_ns (of p/T) would be a second column of the log "
        "time's name"
    )
