"""Every natural codec's ``decode`` given the wrong input: a message class, another message."""

from __future__ import annotations

import importlib
from types import SimpleNamespace
from typing import Any

import pytest

from pyconnect import codecs
from pyconnect.codecs.natural import NATURAL_CODECS
from pyconnect.errors import DecodeError


def message_class(full_name: str) -> Any:
    package, namespace, name = full_name.split("/")
    return getattr(importlib.import_module(f"{package}.{namespace}"), name)


def another_message(full_name: str) -> tuple[Any, str]:
    """A message of another type than ``full_name``, and its type's name."""
    from geometry_msgs.msg import Point
    from sensor_msgs.msg import Image

    if full_name == "geometry_msgs/msg/Point":
        return Image(), "sensor_msgs/msg/Image"
    return Point(), "geometry_msgs/msg/Point"


@pytest.mark.parametrize("full_name", sorted(NATURAL_CODECS))
def test_a_natural_codec_given_another_message_names_both_types(full_name: str) -> None:
    # They raised bare AttributeErrors ('Point' object has no attribute 'linear'), or returned
    # a value (Vector3's codec read a Point's x, y, z).
    other, other_name = another_message(full_name)
    with pytest.raises(DecodeError) as raised:
        codecs.lookup(full_name).decode(other)
    assert str(raised.value) == f"expected {full_name}, got {other_name}"


@pytest.mark.parametrize("full_name", sorted(NATURAL_CODECS))
def test_a_natural_codec_given_its_message_class_says_to_make_a_message(full_name: str) -> None:
    # Image's raised "expected string or bytes-like object, got 'property'"; String's returned
    # '<property object ...>', Vector3's a tuple of three properties.
    cls = message_class(full_name)
    name = cls.__name__
    with pytest.raises(DecodeError) as raised:
        codecs.lookup(full_name).decode(cls)
    assert str(raised.value) == f"expected a message, got the class {name}; did you mean {name}()?"


@pytest.mark.parametrize("full_name", sorted(NATURAL_CODECS))
def test_a_natural_codec_given_another_message_class_names_its_type(full_name: str) -> None:
    from geometry_msgs.msg import Point
    from sensor_msgs.msg import Image

    cls = Image if full_name == "geometry_msgs/msg/Point" else Point
    with pytest.raises(DecodeError) as raised:
        codecs.lookup(full_name).decode(cls)
    assert str(raised.value) == f"expected {full_name}, got the class {cls.__name__}"


def _same_shape_cases() -> list[tuple[str, Any, str]]:
    from builtin_interfaces.msg import Duration
    from geometry_msgs.msg import Point, PoseStamped
    from nav_msgs.msg import Odometry, Path
    from sensor_msgs.msg import PointCloud
    from std_msgs.msg import Bool, Float64, Float64MultiArray, Int32, Int64

    return [
        ("std_msgs/msg/String", Int32(data=5), "std_msgs/msg/Int32"),  # returned '5'
        ("std_msgs/msg/Int32", Float64(data=1.5), "std_msgs/msg/Float64"),  # returned 1
        ("std_msgs/msg/Int32", Bool(data=True), "std_msgs/msg/Bool"),
        ("std_msgs/msg/Float64", Int32(data=5), "std_msgs/msg/Int32"),  # returned 5.0
        ("std_msgs/msg/Bool", Int32(data=5), "std_msgs/msg/Int32"),  # returned True
        ("std_msgs/msg/Byte", Float64(data=1.5), "std_msgs/msg/Float64"),
        ("std_msgs/msg/Empty", Int32(data=5), "std_msgs/msg/Int32"),  # returned None
        ("std_msgs/msg/Int32", Int64(data=2**40), "std_msgs/msg/Int64"),  # returned 2**40
        ("std_msgs/msg/UInt8", Int64(data=-5), "std_msgs/msg/Int64"),  # returned -5
        ("std_msgs/msg/Float32", Float64(data=1e300), "std_msgs/msg/Float64"),  # returned 1e300
        (
            "std_msgs/msg/Int8MultiArray",
            Float64MultiArray(data=[1.5]),
            "std_msgs/msg/Float64MultiArray",
        ),
        (
            "geometry_msgs/msg/Vector3",
            Point(),
            "geometry_msgs/msg/Point",
        ),  # returned (0.0, 0.0, 0.0)
        ("geometry_msgs/msg/Point32", Point(), "geometry_msgs/msg/Point"),
        ("geometry_msgs/msg/Polygon", PointCloud(), "sensor_msgs/msg/PointCloud"),
        ("builtin_interfaces/msg/Time", Duration(sec=1), "builtin_interfaces/msg/Duration"),
        ("geometry_msgs/msg/PoseStamped", Odometry(), "nav_msgs/msg/Odometry"),
        ("geometry_msgs/msg/PoseArray", Path(poses=[PoseStamped()]), "nav_msgs/msg/Path"),
    ]


@pytest.mark.parametrize(("full_name", "given", "given_name"), _same_shape_cases())
def test_a_message_with_fields_of_the_same_names_is_still_another_type(
    full_name: str, given: Any, given_name: str
) -> None:
    with pytest.raises(DecodeError) as raised:
        codecs.lookup(full_name).decode(given)
    assert str(raised.value) == f"expected {full_name}, got {given_name}"


def test_wire_views_and_rosbags_messages_of_another_type_are_named_by_their_type() -> None:
    from geometry_msgs.msg import Point
    from rclpy.serialization import serialize_message
    from rosbags.typesys import Stores, get_typestore

    cdr = bytes(serialize_message(Point(x=1.0)))
    view = codecs.default_registry.wire_codec("geometry_msgs/msg/Point").decode_view(cdr)
    rosbags_point = get_typestore(Stores.ROS2_JAZZY).deserialize_cdr(cdr, "geometry_msgs/msg/Point")
    for given in (view, rosbags_point):
        with pytest.raises(DecodeError) as raised:
            codecs.lookup("geometry_msgs/msg/Vector3").decode(given)
        assert (
            str(raised.value) == "expected geometry_msgs/msg/Vector3, got geometry_msgs/msg/Point"
        )
        assert codecs.lookup("geometry_msgs/msg/Point").decode(given) == (1.0, 0.0, 0.0)


def test_a_stand_in_naming_no_type_is_read_by_its_fields() -> None:
    vector3 = codecs.lookup("geometry_msgs/msg/Vector3")
    assert vector3.decode(SimpleNamespace(x=1.0, y=2.0, z=3.0)) == (1.0, 2.0, 3.0)
    assert codecs.lookup("std_msgs/msg/String").decode(SimpleNamespace(data="hi")) == "hi"
    with pytest.raises(DecodeError) as missing:
        vector3.decode(SimpleNamespace(x=1.0))
    assert str(missing.value) == "expected geometry_msgs/msg/Vector3, got SimpleNamespace"
    with pytest.raises(DecodeError) as wrong:
        codecs.lookup("std_msgs/msg/String").decode(SimpleNamespace(data=3))
    assert str(wrong.value) == "String.data: expected str, got int"
