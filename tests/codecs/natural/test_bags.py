"""Decoding the rosbags_rs sample bags: rosbags objects and rclpy messages give the same values."""

from __future__ import annotations

import importlib
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rclpy import serialization
from rosbags import highlevel, typesys

from pyconnect import codecs
from pyconnect.codecs.natural import NATURAL_CODECS
from pyconnect.errors import DecodeError
from tests.codecs.natural.helpers import ROSBAGS_RS, same
from tests.codecs.natural.test_point_cloud import agrees
from tests.conftest import require_sample_bags

require_sample_bags(ROSBAGS_RS, ROSBAGS_RS.is_dir())

INTERESTING = set(NATURAL_CODECS) | {"stereo_msgs/msg/DisparityImage"}


def rclpy_class(type_name: str) -> Any:
    package, namespace, name = type_name.split("/")
    return getattr(importlib.import_module(f"{package}.{namespace}"), name)


def read_bag(path: Path) -> Iterator[tuple[str, Any, Any]]:
    """(type, rosbags message, rclpy message) for every message of an interesting type."""
    store = typesys.get_typestore(typesys.Stores.ROS2_JAZZY)
    with highlevel.AnyReader([path], default_typestore=store) as reader:
        for connection, _, raw in reader.messages():
            if connection.msgtype not in INTERESTING:
                continue
            yield (
                connection.msgtype,
                reader.deserialize(raw, connection.msgtype),
                serialization.deserialize_message(raw, rclpy_class(connection.msgtype)),
            )


@pytest.fixture(scope="module", params=["test_bag_mcap", "test_bag_sqlite3"])
def bag_messages(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> list[tuple[str, Any, Any]]:
    source = ROSBAGS_RS / request.param
    # sqlite bags are copied first: opening them in place may leave -wal/-shm files (SOURCES.md).
    copy = tmp_path_factory.mktemp("bag") / request.param
    shutil.copytree(source, copy)
    return list(read_bag(copy))


def decode_or_error(msg: Any) -> Any:
    try:
        return codecs.lookup(getattr(msg, "__msgtype__", None) or type(msg)).decode(msg)
    except DecodeError as error:
        return f"DecodeError: {error}"


def test_every_natural_type_in_the_bag_decodes_alike_from_rosbags_and_rclpy(
    bag_messages: list[tuple[str, Any, Any]],
) -> None:
    seen = set()
    for type_name, rosbags_msg, rclpy_msg in bag_messages:
        if type_name == "stereo_msgs/msg/DisparityImage":
            ours = decode_or_error(rclpy_msg.image)
            theirs = decode_or_error(rosbags_msg.image)
        else:
            ours = decode_or_error(rclpy_msg)
            theirs = decode_or_error(rosbags_msg)
        assert same(theirs, ours), type_name
        seen.add(type_name)
    assert {
        "sensor_msgs/msg/Image",
        "sensor_msgs/msg/CompressedImage",
        "sensor_msgs/msg/PointCloud2",
        "sensor_msgs/msg/LaserScan",
        "sensor_msgs/msg/JointState",
        "nav_msgs/msg/OccupancyGrid",
    } <= seen
    assert len(seen) >= 50


def by_type(bag_messages: list[tuple[str, Any, Any]], type_name: str) -> list[tuple[Any, Any]]:
    found = [(r, m) for t, r, m in bag_messages if t == type_name]
    assert found, type_name
    return found


def test_images_shorter_than_step_times_height(bag_messages: list[tuple[str, Any, Any]]) -> None:
    for rosbags_msg, rclpy_msg in by_type(bag_messages, "sensor_msgs/msg/Image"):
        for msg in (rosbags_msg, rclpy_msg):
            with pytest.raises(DecodeError) as error:
                codecs.lookup("sensor_msgs/Image").decode(msg)
            assert str(error.value) == (
                "Image.data: expected at least 921600 bytes (step 1920 × height 480), got 30"  # noqa: RUF001
            )
    for _, rclpy_msg in by_type(bag_messages, "stereo_msgs/msg/DisparityImage"):
        with pytest.raises(DecodeError) as error:
            codecs.lookup("sensor_msgs/Image").decode(rclpy_msg.image)
        assert str(error.value) == (
            "Image.data: expected at least 1228800 bytes (step 2560 × height 480), got 400"  # noqa: RUF001
        )


def test_truncated_jpeg(bag_messages: list[tuple[str, Any, Any]]) -> None:
    for _, rclpy_msg in by_type(bag_messages, "sensor_msgs/msg/CompressedImage"):
        with pytest.raises(DecodeError) as error:
            codecs.decode(rclpy_msg)
        assert str(error.value) == "CompressedImage.data: cannot decode 10 bytes as jpeg"


def test_point_cloud_scan_and_joints(bag_messages: list[tuple[str, Any, Any]]) -> None:
    for rosbags_msg, rclpy_msg in by_type(bag_messages, "sensor_msgs/msg/PointCloud2"):
        cloud = codecs.decode(rclpy_msg)
        assert cloud.shape == (3,) and cloud.dtype.names == ("x", "y", "z")
        assert agrees(cloud, rclpy_msg) and agrees(
            codecs.lookup("sensor_msgs/PointCloud2").decode(rosbags_msg), rclpy_msg
        )
    for _, rclpy_msg in by_type(bag_messages, "sensor_msgs/msg/LaserScan"):
        scan = codecs.decode(rclpy_msg)
        assert scan.ranges.tolist() == [1.0, 2.0, 3.0, 4.0, 5.0]
        assert scan.intensities.tolist() == [100.0, 200.0, 300.0, 400.0, 500.0]
        assert scan.range_max == 10.0 and scan.angle_min == float(np.float32(-1.57))
    for _, rclpy_msg in by_type(bag_messages, "sensor_msgs/msg/JointState"):
        assert codecs.decode(rclpy_msg) == {
            "joint1": {"position": 0.1, "velocity": 0.01, "effort": 1.0},
            "joint2": {"position": 0.2, "velocity": 0.02, "effort": 2.0},
            "joint3": {"position": 0.3, "velocity": 0.03, "effort": 3.0},
        }
        stamped = codecs.decode(rclpy_msg, stamped=True)
        assert stamped.frame_id == "test_frame" and stamped.stamp_ns > 1_749_315_000 * 10**9
    for _, rclpy_msg in by_type(bag_messages, "nav_msgs/msg/OccupancyGrid"):
        grid = codecs.decode(rclpy_msg)
        assert grid.cells.shape == (10, 10) and grid.origin == (
            (0.0, 0.0, 0.0),
            (0.0, 0.0, 0.0, 1.0),
        )
