"""geometry_msgs and nav_msgs/Path ↔ tuples: round trips, shorthand, errors."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from pyconnect import codecs
from pyconnect.errors import EncodeError
from tests.codecs.natural.helpers import EXAMPLES, same, wire_view

pytest.importorskip("geometry_msgs.msg")

floats = st.floats(allow_nan=True, allow_infinity=True)
floats32 = st.floats(width=32, allow_nan=True, allow_infinity=True)
triple = st.tuples(floats, floats, floats)
quad = st.tuples(floats, floats, floats, floats)
pose = st.tuples(triple, quad)
pair = st.tuples(triple, triple)

VALUES: dict[str, st.SearchStrategy[Any]] = {
    "geometry_msgs/msg/Vector3": triple,
    "geometry_msgs/msg/Point": triple,
    "geometry_msgs/msg/Point32": st.tuples(floats32, floats32, floats32),
    "geometry_msgs/msg/Quaternion": quad,
    "geometry_msgs/msg/Pose2D": triple,
    "geometry_msgs/msg/Pose": pose,
    "geometry_msgs/msg/Transform": pose,
    "geometry_msgs/msg/Twist": pair,
    "geometry_msgs/msg/Accel": pair,
    "geometry_msgs/msg/Wrench": pair,
    "geometry_msgs/msg/PoseArray": st.lists(pose, max_size=4),
    "nav_msgs/msg/Path": st.lists(pose, max_size=4),
    "geometry_msgs/msg/PointStamped": triple,
    "geometry_msgs/msg/Vector3Stamped": triple,
    "geometry_msgs/msg/QuaternionStamped": quad,
    "geometry_msgs/msg/PoseStamped": pose,
    "geometry_msgs/msg/TransformStamped": pose,
    "geometry_msgs/msg/TwistStamped": pair,
    "geometry_msgs/msg/AccelStamped": pair,
    "geometry_msgs/msg/WrenchStamped": pair,
}


@EXAMPLES
@given(st.sampled_from(sorted(VALUES)).flatmap(lambda t: st.tuples(st.just(t), VALUES[t])))
def test_round_trip_is_bit_exact(case: tuple[str, Any]) -> None:
    type_name, value = case
    codec = codecs.lookup(type_name)
    msg = codec.encode(value)
    assert same(codec.decode(msg), value)
    assert same(codec.decode(wire_view(msg)), value)
    # to_fields gives the lossless dict shape: the dict codec builds the same message from it.
    assert same(codec.decode(codecs.from_dict(codec.to_fields(value), type_name)), value)


@EXAMPLES
@given(st.lists(st.tuples(floats32, floats32, floats32), max_size=5))
def test_polygon_round_trips_as_an_n_by_3_float32_array(points: list[Any]) -> None:
    codec = codecs.lookup("geometry_msgs/msg/Polygon")
    array = np.array(points, np.float32).reshape(-1, 3)
    decoded = codec.decode(codec.encode(array))
    assert same(decoded, array)
    assert same(codec.decode(codec.encode(points)), array)
    stamped = codecs.lookup("geometry_msgs/msg/PolygonStamped")
    assert same(stamped.decode(stamped.encode(array)), array)


def test_planar_shorthand() -> None:
    msg = codecs.encode((0.5, -0.25), "geometry_msgs/Twist")
    assert codecs.decode(msg) == ((0.5, 0.0, 0.0), (0.0, 0.0, -0.25))
    assert codecs.lookup("geometry_msgs/Twist").to_fields((1, 2)) == {
        "linear": {"x": 1.0, "y": 0.0, "z": 0.0},
        "angular": {"x": 0.0, "y": 0.0, "z": 2.0},
    }


def test_ints_and_numpy_values_are_accepted() -> None:
    msg = codecs.encode(((1, 2, np.float32(3)), [0, 0, 0, 1]), "geometry_msgs/Pose")
    assert codecs.decode(msg) == ((1.0, 2.0, 3.0), (0.0, 0.0, 0.0, 1.0))
    assert codecs.decode(codecs.encode(np.array([1.0, 2.0, 3.0]), "geometry_msgs/Point")) == (
        1.0,
        2.0,
        3.0,
    )


@pytest.mark.parametrize(
    ("type_name", "value", "message"),
    [
        (
            "geometry_msgs/Twist",
            {"linear": 1},
            ("Twist: expected ((x, y, z), (x, y, z)) or (v, w), got dict"),
        ),
        (
            "geometry_msgs/Twist",
            ((1.0, 2.0), (0.0, 0.0, 0.0)),
            ("Twist.linear: expected (x, y, z), got tuple of length 2"),
        ),
        (
            "geometry_msgs/Twist",
            ((1.0, "2", 0.0), (0.0, 0.0, 0.0)),
            ("Twist.linear.y: expected float, got str"),
        ),
        ("geometry_msgs/Twist", (True, 0.0), "Twist.linear.x: expected float, got bool"),
        (
            "geometry_msgs/Pose",
            ((0.0, 0.0, 0.0), {"w": 1.0}),
            ("Pose.orientation: expected (x, y, z, w), got dict"),
        ),
        ("geometry_msgs/Vector3", "xyz", "Vector3: expected (x, y, z), got str"),
        (
            "geometry_msgs/Point32",
            (1e39, 0.0, 0.0),
            ("Point32.x: expected float32 (|x| < 3.4028235677973366e+38), got 1e+39"),
        ),
        (
            "geometry_msgs/PoseArray",
            {"poses": []},
            ("PoseArray.poses: expected a list of poses, got dict"),
        ),
        (
            "geometry_msgs/PoseArray",
            [((0.0, 0.0, 0.0), (0.0, 0.0, 1.0))],
            ("PoseArray.poses[0].orientation: expected (x, y, z, w), got tuple of length 3"),
        ),
        (
            "geometry_msgs/Polygon",
            [(1.0, 2.0)],
            (
                "Polygon.points: expected an (N, 3) array of floats, got list of shape (1, 2) "
                "and dtype float64"
            ),
        ),
        (
            "geometry_msgs/TwistStamped",
            [1.0],
            ("TwistStamped.twist: expected ((x, y, z), (x, y, z)) or (v, w), got list of length 1"),
        ),
    ],
)
def test_bad_values_name_the_path(type_name: str, value: Any, message: str) -> None:
    with pytest.raises(EncodeError) as error:
        codecs.encode(value, type_name)
    assert str(error.value) == message


def test_lossless_is_honest() -> None:
    for type_name in ("Vector3", "Point", "Point32", "Quaternion", "Pose", "Twist", "Polygon"):
        assert codecs.lookup(f"geometry_msgs/{type_name}").lossless is True
    for type_name in ("PoseStamped", "TransformStamped", "PoseArray"):
        assert codecs.lookup(f"geometry_msgs/{type_name}").lossless is False
    assert codecs.lookup("nav_msgs/Path").lossless is False


@pytest.mark.parametrize(
    ("type_name", "value", "message"),
    [
        (
            "geometry_msgs/msg/Polygon",
            [(1.0, True, 0.0)],
            "Polygon.points[0].y: expected float, got bool",
        ),
        (
            "geometry_msgs/msg/PolygonStamped",
            [(1.0, 2.0, 3.0), (np.False_, 0.0, 0.0)],
            "PolygonStamped.polygon.points[1].x: expected float, got numpy.bool",
        ),
        (
            "geometry_msgs/msg/Polygon",
            [np.array([1.0, 2.0, 3.0]), np.array([True, False, True])],
            "Polygon.points[1].x: expected float, got numpy.bool",
        ),
        (
            "geometry_msgs/msg/PoseArray",
            [((1.0, True, 0.0), (0.0, 0.0, 0.0, 1.0))],
            "PoseArray.poses[0].position.y: expected float, got bool",
        ),
        (
            "nav_msgs/msg/Path",
            [((0.0, 0.0, 0.0), (0.0, 0.0, True, 1.0))],
            "Path.poses[0].orientation.z: expected float, got bool",
        ),
        (
            "geometry_msgs/msg/Polygon",
            np.array([[0.0, 0.0, 0.0], [1.0, 2.0, -1e39]]),
            "Polygon.points[1].z: expected float32 (|x| < 3.4028235677973366e+38), got -1e+39",
        ),
        (
            "geometry_msgs/msg/PolygonStamped",
            [(1e39, 0.0, 0.0)],
            "PolygonStamped.polygon.points[0].x: expected float32 "
            "(|x| < 3.4028235677973366e+38), got 1e+39",
        ),
    ],
)
def test_geometry_arrays_refuse_bools_and_name_overflows_on_both_paths(
    type_name: str, value: Any, message: str
) -> None:
    with pytest.raises(EncodeError) as error:
        codecs.default_registry.encode(value, type_name)
    assert str(error.value) == message
    with pytest.raises(EncodeError) as error:
        codecs.wire.encode(value, type_name)
    assert str(error.value) == message


def test_polygon_takes_numbers_of_every_kind_and_float32s_edge() -> None:
    codec = codecs.lookup("geometry_msgs/msg/Polygon")
    mixed = [(1, 2.5, np.float32(3.0)), (np.int8(-4), np.float64(5.0), 6)]
    assert codec.decode(codec.encode(mixed)).tolist() == [[1.0, 2.5, 3.0], [-4.0, 5.0, 6.0]]
    # Just above FLOAT32_MAX rounds to it, as struct.pack("<f") and check_float32 have it.
    edge = np.array([[3.4028235e38 * (1 + 1e-9), np.inf, np.nan]])
    decoded = codec.decode(codec.encode(edge))
    assert decoded[0, 0] == np.finfo(np.float32).max and np.isinf(decoded[0, 1])
