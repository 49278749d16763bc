"""The natural-codec table, ``Stamped`` for any type with a Header, and the import contract."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from pyconnect import codecs
from pyconnect.codecs.base import Codec
from pyconnect.codecs.natural import NATURAL_CODECS
from pyconnect.codecs.stamped import Stamped, header_of
from pyconnect.errors import DecodeError, EncodeError
from tests.codecs.natural.helpers import wire_view


@pytest.mark.parametrize("type_name", sorted(NATURAL_CODECS))
def test_every_table_entry_is_a_codec_of_its_type(type_name: str) -> None:
    codec = codecs.lookup(type_name)
    assert isinstance(codec, Codec)
    assert codec.msg_type == type_name
    assert isinstance(codec.lossless, bool)
    assert callable(getattr(codec, "to_fields", None))
    module = sys.modules[type(codec).__module__]
    assert module.__doc__ and "\n" in module.__doc__  # says what it is and what it drops


def test_issue_types_are_covered() -> None:
    wanted = {
        "sensor_msgs/msg/Image",
        "sensor_msgs/msg/CompressedImage",
        "sensor_msgs/msg/PointCloud2",
        "sensor_msgs/msg/LaserScan",
        "sensor_msgs/msg/JointState",
        "nav_msgs/msg/OccupancyGrid",
        "nav_msgs/msg/Path",
        "geometry_msgs/msg/PoseArray",
        "geometry_msgs/msg/Polygon",
        "std_msgs/msg/Float64MultiArray",
        "std_msgs/msg/String",
        "std_msgs/msg/Empty",
        "std_msgs/msg/ColorRGBA",
        "builtin_interfaces/msg/Time",
        "builtin_interfaces/msg/Duration",
        "geometry_msgs/msg/TwistStamped",
        "geometry_msgs/msg/Wrench",
    }
    assert wanted <= set(NATURAL_CODECS)


def test_codecs_import_without_numpy_or_rclpy() -> None:
    code = (
        "import sys, pyconnect.codecs, pyconnect.codecs.natural, pyconnect.codecs.stamped;"
        "bad = [m for m in sys.modules if m.split('.')[0] in ('numpy', 'rclpy', 'cv2',"
        " 'sensor_msgs')]; print(bad); sys.exit(1 if bad else 0)"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=False
    )
    assert result.returncode == 0, result.stdout + result.stderr


def test_services_stay_dicts_unless_the_part_is_natural() -> None:
    service = codecs.lookup("std_srvs/srv/SetBool")
    assert type(service.request).__name__ == "DictCodec"


def test_stamped_decode_and_encode_for_natural_and_dict_types() -> None:
    image = np.zeros((2, 2), np.uint8)
    msg = codecs.encode(Stamped(image, 1_700_000_000_123_456_789, "camera"), "sensor_msgs/Image")
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id) == (
        1_700_000_000,
        123_456_789,
        "camera",
    )
    stamped = codecs.decode(msg, stamped=True)
    assert (stamped.stamp_ns, stamped.frame_id) == (1_700_000_000_123_456_789, "camera")
    assert np.array_equal(stamped.value, image)
    twist = codecs.encode(
        Stamped(((1.0, 0.0, 0.0), (0.0, 0.0, 0.5)), 5, "base"), "geometry_msgs/TwistStamped"
    )
    assert codecs.decode(twist, stamped=True) == Stamped(
        ((1.0, 0.0, 0.0), (0.0, 0.0, 0.5)), 5, "base"
    )
    # A dict-codec type with a header (no natural codec) works the same way.
    imu = codecs.encode(Stamped({}, 7, "imu"), "sensor_msgs/Imu")
    assert codecs.decode(imu, stamped=True).stamp_ns == 7


def test_header_is_found_by_duck_typing() -> None:
    from sensor_msgs.msg import Image
    from std_msgs.msg import Header

    view = wire_view(Image(header=Header(frame_id="f")))
    assert header_of(view).frame_id == "f"
    header = Header(frame_id="h")
    assert header_of(header) is header
    assert header_of(wire_view(codecs.encode((1.0, 2.0, 3.0), "geometry_msgs/Point"))) is None


def test_stamped_without_a_header() -> None:
    msg = codecs.encode((1.0, 2.0, 3.0), "geometry_msgs/Point")
    with pytest.raises(DecodeError) as error:
        codecs.decode(msg, stamped=True)
    assert str(error.value) == (
        "geometry_msgs/msg/Point: has no std_msgs/Header, so it cannot be Stamped"
    )
    with pytest.raises(EncodeError) as encode_error:
        codecs.encode(Stamped((1.0, 2.0, 3.0), 0), "geometry_msgs/Point")
    assert str(encode_error.value) == (
        "geometry_msgs/msg/Point: has no std_msgs/Header, so it cannot take a Stamped"
    )


def test_every_natural_codec_has_a_hypothesis_round_trip() -> None:
    from tests.codecs.natural import test_geometry, test_std_scalars
    from tests.codecs.natural.test_arrays import DTYPES

    covered = set(test_geometry.VALUES) | set(test_std_scalars.VALUES)
    covered |= {f"std_msgs/msg/{name}" for name in DTYPES}
    covered |= {  # their own hypothesis tests: test_image, test_compressed_image (png), …
        "sensor_msgs/msg/Image",
        "sensor_msgs/msg/CompressedImage",
        "sensor_msgs/msg/PointCloud2",
        "sensor_msgs/msg/LaserScan",
        "sensor_msgs/msg/JointState",
        "nav_msgs/msg/OccupancyGrid",
        "geometry_msgs/msg/Polygon",
        "geometry_msgs/msg/PolygonStamped",
    }
    assert set(NATURAL_CODECS) <= covered, sorted(set(NATURAL_CODECS) - covered)


@pytest.mark.parametrize(
    ("stamp_ns", "error"),
    [
        # rclpy's setters check nothing: 2038 + 1 s went out as 1901, a float failed inside
        # serialize_message with a SystemError.
        (2**31 * 10**9, "Stamped.stamp_ns.sec: expected int32 in [-2147483648, 2147483647], got 2147483648"),
        (1.7e18, "Stamped.stamp_ns: expected int nanoseconds, got float"),
        ("now", "Stamped.stamp_ns: expected int nanoseconds, got str"),
        (True, "Stamped.stamp_ns: expected int nanoseconds, got bool"),
    ],
)  # fmt: skip
def test_a_stamp_that_does_not_fit_a_header_is_refused(stamp_ns: object, error: str) -> None:
    from geometry_msgs.msg import PoseStamped

    from pyconnect.codecs import wire

    value = Stamped(((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)), stamp_ns, "map")
    with pytest.raises(EncodeError) as caught:
        codecs.encode(value, PoseStamped)
    assert str(caught.value) == error
    with pytest.raises(EncodeError) as caught:
        wire.encode(value, "geometry_msgs/msg/PoseStamped")
    assert str(caught.value) == error


def test_a_numpy_integer_stamp_is_an_int() -> None:
    from geometry_msgs.msg import PoseStamped
    from rclpy.serialization import deserialize_message, serialize_message

    value = Stamped(((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)), np.int64(5_000_000_001), "map")
    stamp = deserialize_message(serialize_message(codecs.encode(value, PoseStamped)), PoseStamped)
    assert (stamp.header.stamp.sec, stamp.header.stamp.nanosec) == (5, 1)


@pytest.mark.parametrize(
    ("type_name", "value", "error"),
    [
        ("geometry_msgs/msg/PoseStamped", ((0, 0, 0), (0, 0, "w", 1)),
         "PoseStamped.pose.orientation.z: expected float, got str"),
        ("geometry_msgs/msg/TwistStamped", "x",
         "TwistStamped.twist: expected ((x, y, z), (x, y, z)) or (v, w), got str"),
        ("geometry_msgs/msg/TransformStamped", ((0, 0), (0, 0, 0, 1)),
         "TransformStamped.transform.translation: expected (x, y, z), got tuple of length 2"),
    ],
)  # fmt: skip
def test_an_error_inside_a_stamped_type_names_its_whole_path(
    type_name: str, value: object, error: str
) -> None:
    # The inner codec named its own type: "Pose.orientation.z" said nothing of PoseStamped.
    from pyconnect.codecs import wire

    with pytest.raises(EncodeError) as caught:
        codecs.encode(value, type_name)
    assert str(caught.value) == error
    with pytest.raises(EncodeError) as caught:
        wire.encode(value, type_name)
    assert str(caught.value) == error


@pytest.mark.parametrize(
    ("type_name", "value"),
    [
        ("geometry_msgs/msg/TwistStamped", ((1.0, 2.0, 3.0), (0.0, 0.0, 0.5))),
        ("geometry_msgs/msg/PoseStamped", ((1.0, 2.0, 3.0), (0.0, 0.0, 0.0, 1.0))),
        ("sensor_msgs/msg/Image", np.zeros((2, 3), np.uint8)),
        # A Header is its own header (codecs.decode(header, stamped=True) gives such a value);
        # the wire path looked for a Header field in it and refused.
        ("std_msgs/msg/Header", {"stamp": {"sec": 3, "nanosec": 0}, "frame_id": "cam"}),
    ],
)
def test_the_wire_path_writes_a_stamped_value_as_the_message_path(
    type_name: str, value: object
) -> None:
    # A Peer's pub and wire.encode refused a Stamped ("Twist: expected ..., got Stamped").
    from rclpy.serialization import deserialize_message, serialize_message

    from pyconnect.codecs import wire

    stamped = Stamped(value, 5_000_000_001, "base")
    msg_class = type(codecs.encode(stamped, type_name))
    cdr = wire.encode(stamped, type_name)
    assert deserialize_message(cdr, msg_class) == deserialize_message(
        serialize_message(codecs.encode(stamped, type_name)), msg_class
    )


def test_the_wire_path_refuses_a_stamped_value_for_a_type_without_header() -> None:
    from pyconnect.codecs import wire

    with pytest.raises(EncodeError) as caught:
        wire.encode(Stamped("hi", 0, ""), "std_msgs/msg/String")
    assert str(caught.value) == "std_msgs/msg/String: has no std_msgs/Header, so it cannot take a Stamped"

