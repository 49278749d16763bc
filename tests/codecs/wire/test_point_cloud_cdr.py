"""A large cloud's CDR, written in one pass over its points, is the general path's, byte for byte."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import PointCloud2

from pyconnect.codecs import point_cloud_cdr, wire
from pyconnect.codecs.point_cloud import PointCloudCodec, point_cloud_fields
from pyconnect.codecs.registry import Registry, default_registry

CLOUD = point_cloud_cdr.CLOUD


def general_path(points: Any) -> bytes:
    """The CDR of ``points`` the general way: ``to_fields`` (is_dense read), then ``from_dict``."""
    return wire.wire_codec(CLOUD).from_dict(point_cloud_fields(points))


def cloud(layout: str, count: int, spots: list[tuple[float, float]]) -> Any:
    """Points of a layout (``n3``: an (N, 3) array), odd numbers at the ``spots`` of ``y``."""
    kinds = {"xyz": "<f4", "xyzrgb": "<f4", "organised": "<f4", "xyz64": "<f8"}
    if layout == "n3":
        points: Any = np.zeros((count, 3), np.float32)
        flat = points.reshape(-1)
    else:
        names = ["x", "y", "z"] + (["rgb"] if layout == "xyzrgb" else [])
        points = np.zeros(count * (2 if layout == "organised" else 1),
                          [(n, kinds[layout]) for n in names])  # fmt: skip
        if layout == "organised":
            points = points.reshape(2, count)
        flat = points.reshape(-1)["y"]
    for where, number in spots:
        if flat.size:
            flat[int(where * flat.size)] = number
    return points


@settings(max_examples=40, deadline=None, database=None)
@given(
    count=st.sampled_from([0, 1, 3, 7, 1000]),
    layout=st.sampled_from(["xyz", "xyzrgb", "organised", "xyz64", "n3"]),
    spots=st.lists(
        st.tuples(
            st.floats(0, 1, exclude_max=True), st.sampled_from([np.nan, np.inf, 3.0e38, 0.5])
        ),
        max_size=2,
    ),
)
def test_wire_encode_in_one_pass_is_the_general_path(
    count: int, layout: str, spots: list[tuple[float, float]]
) -> None:
    """Every size takes the one-pass writer here (threshold 0): same bytes, every alignment,
    the same exact ``is_dense`` (a NaN, an inf, or a huge but finite coordinate)."""
    points = cloud(layout, count, spots)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(point_cloud_cdr, "IN_ONE_PASS_BYTES", 0)
        assert point_cloud_cdr.writes_in_one_pass(PointCloudCodec(), points)
        fast = wire.encode(points, CLOUD)
    assert fast == general_path(points)


@pytest.mark.parametrize("spoiled", [None, "first", "last"])
def test_a_large_cloud_as_rclpy_reads_it(spoiled: str | None) -> None:
    """Above the threshold by default (many chunks): rclpy reads the one-pass bytes as
    the message the class path builds, ``is_dense`` false for a NaN in the first or last chunk."""
    points = np.zeros(700_000, [(n, "<f4") for n in ("x", "y", "z", "rgb")])  # 11.2 MB
    points["z"] = np.linspace(0.0, 1.0, points.size, dtype=np.float32)
    if spoiled is not None:
        points["x"][0 if spoiled == "first" else -1] = np.nan
    assert point_cloud_cdr.writes_in_one_pass(PointCloudCodec(), points)
    cdr = wire.encode(points, CLOUD)
    assert cdr == general_path(points)
    msg = deserialize_message(cdr, PointCloud2)
    assert msg.is_dense is (spoiled is None)
    assert bytes(msg.data) == points.tobytes()
    # rclpy's serializer leaves out the padding after the last field that the wire codecs write.
    by_rclpy = serialize_message(default_registry.encode(points, CLOUD))
    assert cdr[: len(by_rclpy)] == by_rclpy
    assert cdr[len(by_rclpy) :] == bytes(-len(by_rclpy) & 3)


def test_a_user_codec_is_not_bypassed() -> None:
    """A codec the user registered for PointCloud2 writes the fields, however large the value."""

    class HalvedCloud(PointCloudCodec):
        def to_fields(self, value: Any) -> dict[str, Any]:
            return point_cloud_fields(value[: len(value) // 2])

    registry = Registry()
    registry.register(CLOUD, HalvedCloud(), override=True)
    points = np.zeros(200_000, [(n, "<f4") for n in ("x", "y", "z")])
    assert points.nbytes >= point_cloud_cdr.IN_ONE_PASS_BYTES
    cdr = wire.encode(points, CLOUD, registry=registry)
    assert len(deserialize_message(cdr, PointCloud2).data) == points.nbytes // 2


def test_a_small_or_strided_cloud_takes_the_general_path() -> None:
    codec = PointCloudCodec()
    small = np.zeros(10, [(n, "<f4") for n in ("x", "y", "z")])
    strided = np.zeros((200_000, 6), np.float32)[:, ::2]
    assert not point_cloud_cdr.writes_in_one_pass(codec, small)
    assert not point_cloud_cdr.writes_in_one_pass(codec, strided)
    assert not point_cloud_cdr.writes_in_one_pass(codec, small.tolist())
    assert wire.encode(strided, CLOUD) == general_path(strided)
