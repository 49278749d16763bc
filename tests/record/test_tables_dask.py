"""``read_bags`` on a local dask.distributed cluster of worker processes equals the serial reads."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import dask
import pandas as pd
import pytest
from distributed import Client, LocalCluster
from std_msgs.msg import Int32

from pyconnect.errors import PyconnectError
from pyconnect.record import BagError, bag_info, open_bag
from pyconnect.record.dask import BagPart, plan_parts, read_bags
from pyconnect.record.table_pandas import table_to_pandas
from tests.conftest import require_sample_bags
from tests.record.bag_samples import BAGS, expected_bags
from tests.record.table_bags import write_bag
from tests.record.test_bag_damage import write_chunked
from tests.record.test_table_pandas import two_counter_bags
from tests.record.test_tables import _twist_bags, _two_definition_bags, log_time_field_bag

# `make test` reads a slice of the shared bags; `make scale` (PYCONNECT_SCALE=all) reads them all.
SLICE = (
    "evo/nav2_turtlebot.mcap",
    "robot_localization_converted/test2_ros2_mcap_zstd",
    "ros2_rosbag2_jazzy/rosbag2_py/test/resources/sqlite3/wbag",
    "ros2_rosbag2_jazzy/rosbag2_tests/resources/mcap/wrong_rmw_test",
)
EVERY = os.environ.get("PYCONNECT_SCALE") == "all"
SHARED = sorted(name for name in expected_bags() if EVERY or name in SLICE)
LOCALIZATION = [
    BAGS / "robot_localization_converted" / "test1_ros2_mcap_zstd",
    BAGS / "robot_localization_converted" / "test2_ros2_mcap_zstd",
]


@pytest.fixture(scope="module")
def client() -> Iterator[Client]:
    require_sample_bags(BAGS, bool(SHARED))
    with (
        LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
        ) as cluster,
        Client(cluster) as dask_client,
    ):
        yield dask_client


def _serial(paths: list[Path], topic: str) -> pd.DataFrame:
    frames = []
    for path in paths:
        with open_bag(path, topics=[topic]) as bag:
            frames.append(bag.to_pandas(topic))
    return pd.concat(frames, ignore_index=True)


def test_every_shared_bag_reads_the_same_on_the_cluster(client: Client) -> None:
    planned: list[tuple[str, str, object]] = []
    expected: list[pd.DataFrame] = []
    refused = 0
    for name in SHARED:
        path = BAGS / name
        for topic in bag_info(path).topics:
            try:
                serial = _serial([path], topic.name)
            except PyconnectError as error:  # not CDR, or no definition at all: refused alike
                with pytest.raises(type(error)) as raised:
                    read_bags([path], topic=topic.name)
                assert str(raised.value) == str(error)
                refused += 1
                continue
            planned.append((name, topic.name, read_bags([path], topic=topic.name)))
            expected.append(serial)
    results = dask.compute(*[frame for _name, _topic, frame in planned])
    assert len(results) > (200 if EVERY else 8)
    for (name, topic, _frame), result, serial in zip(planned, results, expected, strict=True):
        assert list(result.columns) == list(serial.columns), (name, topic)
        pd.testing.assert_frame_equal(result.reset_index(drop=True), serial, obj=f"{name} {topic}")
    assert refused < 10


def test_many_bags_split_by_chunks_give_the_serial_rows(client: Client) -> None:
    parts = plan_parts(LOCALIZATION[0], "/imu/data", partition_bytes=200_000)
    assert len(parts) > 2
    assert parts[0].start_ns is None and parts[-1].end_ns is None
    frame = read_bags(LOCALIZATION, topic="/imu/data", partition_bytes=200_000)
    assert frame.npartitions == len(parts) + len(
        plan_parts(LOCALIZATION[1], "/imu/data", partition_bytes=200_000)
    )
    result = frame.compute().reset_index(drop=True)
    pd.testing.assert_frame_equal(result, _serial(LOCALIZATION, "/imu/data"))
    assert str(result["orientation_covariance"].iloc[0].dtype) == "float64"


def test_no_paths_is_an_error() -> None:
    with pytest.raises(ValueError) as raised:
        read_bags([], topic="/x")
    assert str(raised.value) == "paths: expected at least one bag"


def test_a_bag_cut_short_reads_as_open_bag_reads_it(tmp_path: Path) -> None:
    # No summary to plan chunk ranges from: one partition, with the rows (and the damage
    # report) of the serial read.
    bag = write_chunked(tmp_path / "bag", count=600)
    file = bag / "bag_0.mcap"
    file.write_bytes(file.read_bytes()[: file.stat().st_size // 2])
    assert plan_parts(bag, "/chatter", partition_bytes=1000) == [BagPart(str(bag), "/chatter")]
    expected = _serial([bag], "/chatter")
    assert 0 < len(expected) < 600
    with dask.config.set(scheduler="synchronous"):
        got = read_bags([bag], topic="/chatter", partition_bytes=1000).compute()
    pd.testing.assert_frame_equal(got.reset_index(drop=True), expected)


def test_bags_of_different_definitions_give_every_partition_the_union(tmp_path: Path) -> None:
    # The first bag's definition lacks a field of the second's: the meta and every partition
    # have the columns of open_bag(bags).to_pandas, nulls where a definition lacks the field.
    bags = _two_definition_bags(tmp_path)
    with open_bag(bags) as bag:
        expected = bag.to_pandas("/s")
    frame = read_bags(bags, topic="/s")
    with dask.config.set(scheduler="synchronous"):
        got = frame.compute()
    assert list(frame.columns) == ["log_time_ns", "data", "extra"]
    pd.testing.assert_frame_equal(got.reset_index(drop=True), expected)


def test_bags_of_two_types_of_the_topic_are_refused_when_planned(tmp_path: Path) -> None:
    # The meta (the columns every partition gets) is the union of open_bag(bags).to_pandas:
    # it refuses two types, so the frame is never planned with half of its columns null.
    old, new = _twist_bags(tmp_path)
    with pytest.raises(BagError) as raised:
        read_bags([old, new], topic="/cmd_vel")
    assert str(raised.value).startswith(
        f"{new}: /cmd_vel: type geometry_msgs/msg/TwistStamped in this bag, "
        f"geometry_msgs/msg/Twist in {old}; "
    )


def test_integers_of_a_field_some_bags_lack_stay_exact(tmp_path: Path) -> None:
    # The meta and every partition give such a column a nullable dtype: to_pandas made it
    # float64 (2**64 - 1 became 2**64) while the meta said uint64.
    bags = two_counter_bags(tmp_path)
    with open_bag(bags) as bag:
        expected = table_to_pandas(bag.to_arrow("/c"))
    frame = read_bags(bags, topic="/c")
    with dask.config.set(scheduler="synchronous"):
        got = frame.compute()
    assert str(frame.dtypes["big"]) == "UInt64" and str(frame.dtypes["kept"]) == "uint64"
    assert dict(got.dtypes) == dict(frame.dtypes)
    pd.testing.assert_frame_equal(got.reset_index(drop=True), expected)
    assert got["big"].tolist() == [pd.NA, 2**64 - 2]
    # A partition without a null follows the meta too.
    with dask.config.set(scheduler="synchronous"):
        second = frame.get_partition(1).compute()
    assert str(second["big"].dtype) == "UInt64" and second["big"].tolist() == [2**64 - 2]


def test_a_field_named_log_time_ns_is_refused_when_planned(tmp_path: Path) -> None:
    bag = log_time_field_bag(tmp_path / "bag")
    with pytest.raises(BagError) as raised:
        read_bags([bag], topic="/ev")
    assert str(raised.value).startswith(f"{bag}: /ev: field log_time_ns of my_logger/msg/Event ")


def test_bags_without_the_topic_give_no_partition(tmp_path: Path) -> None:
    # open_bag(bags).to_pandas(topic) reads the bags that have it; read_bags failed at compute.
    with_a = write_bag(tmp_path / "with_a", [("/a", 1, Int32(data=1)), ("/b", 2, Int32(data=2))])
    without = write_bag(tmp_path / "without", [("/b", 3, Int32(data=3))])
    later = write_bag(tmp_path / "later", [("/a", 4, Int32(data=4))])
    bags = [with_a, without, later]
    assert plan_parts(without, "/a") == []
    frame = read_bags(bags, topic="/a")
    assert frame.npartitions == 2
    with open_bag(bags) as bag:
        expected = bag.to_pandas("/a")
    with dask.config.set(scheduler="synchronous"):
        got = frame.compute()
    pd.testing.assert_frame_equal(got.reset_index(drop=True), expected)
    # No bag with the topic: the error of open_bag, when planned.
    with pytest.raises(BagError) as opened:
        open_bag([without, without], topics=["/a"])
    with pytest.raises(BagError) as raised:
        read_bags([without, without], topic="/a")
    assert str(raised.value) == str(opened.value)


@pytest.mark.parametrize(
    ("value", "error", "message"),
    [
        (0, ValueError, "got 0"),
        (-1, ValueError, "got -1"),
        (True, TypeError, "got True (bool)"),
        (1.5, TypeError, "got 1.5 (float)"),
        (float("nan"), TypeError, "got nan (float)"),
    ],
)
def test_partition_bytes_must_be_a_positive_int(
    tmp_path: Path, value: object, error: type[Exception], message: str
) -> None:
    bag = write_bag(tmp_path / "bag", [("/a", 1, Int32(data=1))])
    for plan in (
        lambda: read_bags([bag], topic="/a", partition_bytes=value),  # type: ignore[arg-type]
        lambda: plan_parts(bag, "/a", partition_bytes=value),  # type: ignore[arg-type]
    ):
        with pytest.raises(error) as raised:
            plan()
        assert str(raised.value) == f"partition_bytes: expected an int > 0, {message}"
