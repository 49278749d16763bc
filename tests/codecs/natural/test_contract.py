"""Natural codecs have one contract (value ⇄ fields); the registry composes encode from it."""

from __future__ import annotations

from typing import Any

import pytest

from pyconnect import codecs
from pyconnect.codecs.base import FieldsCodec, NaturalCodec
from pyconnect.codecs.geometry import PoseCodec, QuaternionCodec, Vector3Codec
from pyconnect.codecs.geometry_twist import TwistCodec
from pyconnect.codecs.image import ImageCodec
from pyconnect.codecs.joint_state import JointStateCodec
from pyconnect.codecs.natural import NATURAL_CODECS
from pyconnect.codecs.point_cloud import PointCloudCodec
from pyconnect.errors import EncodeError
from tests.codecs.natural.test_wire_integration import CASES

# The hot codecs keep a direct encode (composing costs them more than 5 %, bench/natural_codecs;
# 2-3x for the vectors and poses; PointCloud2 copies its data once, not
# three times); every other natural codec writes decode and to_fields only.
DIRECT_ENCODE = (
    ImageCodec,
    JointStateCodec,
    TwistCodec,
    Vector3Codec,
    QuaternionCodec,
    PoseCodec,
    PointCloudCodec,
)


@pytest.mark.parametrize("full_name", sorted(NATURAL_CODECS))
def test_every_natural_codec_follows_the_one_contract(full_name: str) -> None:
    codec = codecs.Registry().value_codec(full_name)
    assert isinstance(codec, FieldsCodec)
    assert isinstance(codec, NaturalCodec)
    assert codec.msg_type == full_name
    if not isinstance(codec, DIRECT_ENCODE):
        assert type(codec).encode is FieldsCodec.encode, type(codec).__name__


@pytest.mark.parametrize(
    ("type_name", "value"), CASES, ids=[f"{t}-{i}" for i, (t, _) in enumerate(CASES)]
)
def test_encode_is_the_generated_code_on_the_fields(type_name: str, value: Any) -> None:
    codec = codecs.lookup(type_name)
    assert isinstance(codec, NaturalCodec)
    assert codec.encode(value) == codecs.from_dict(codec.to_fields(value), type_name)


@pytest.mark.parametrize(
    "value",
    [
        ((0.2, 0.0, 0.0), (0.0, 0.0, 0.5)),  # the direct path
        [[0.2, 0, 0], [0, 0, 0.5]],
        (0.2, 0.5),
        ((1, 2, 3), (4.0, 5.0, 6.0)),
    ],
)
def test_twist_direct_path_agrees_with_the_fields(value: Any) -> None:
    for type_name in ("geometry_msgs/msg/Twist", "geometry_msgs/msg/Accel",
                      "geometry_msgs/msg/Wrench"):  # fmt: skip
        codec = codecs.lookup(type_name)
        assert isinstance(codec, NaturalCodec)
        msg = codec.encode(value)
        assert msg == codecs.from_dict(codec.to_fields(value), type_name)
        assert type(msg).__name__ == type_name.rsplit("/", 1)[1]


def test_the_registry_hands_the_wire_codec_the_fields_codec() -> None:
    registry = codecs.Registry()
    natural = registry.fields_codec("geometry_msgs/Twist")
    assert natural is registry.value_codec("geometry_msgs/msg/Twist")
    assert registry.fields_codec("std_msgs/msg/Header") is None  # its value is the dict


def test_a_codec_made_by_hand_composes_through_the_default_registry() -> None:
    codec = TwistCodec()
    msg = codec.encode((0.5, 0.25))
    assert (msg.linear.x, msg.angular.z) == (0.5, 0.25)
    time_codec = codecs.lookup("builtin_interfaces/msg/Time")
    assert type(time_codec)().encode((1, 2)) == time_codec.encode((1, 2))


class ShoutCodec(FieldsCodec):
    """What the README's "Writing a natural codec" shows: to_fields and decode, nothing else."""

    msg_type = "std_msgs/msg/String"
    lossless = False

    def to_fields(self, value: Any) -> dict[str, Any]:
        return {"data": str(value).upper()}

    def decode(self, msg: Any) -> str:
        return str(msg.data).lower()


def test_a_user_codec_written_as_the_readme_says_gets_encode_and_wire() -> None:
    from pyconnect.codecs import wire

    registry = codecs.Registry()
    registry.register("std_msgs/String", ShoutCodec())
    msg = registry.encode("hi", "std_msgs/msg/String")
    assert msg.data == "HI"
    assert registry.decode(msg) == "hi"
    cdr = wire.encode("hi", "std_msgs/msg/String", registry=registry)
    assert wire.decode(cdr, "std_msgs/msg/String", registry=registry) == "hi"
    assert wire.to_dict(cdr, "std_msgs/msg/String") == {"data": "HI"}


@pytest.mark.parametrize(
    ("type_name", "value"),
    [
        ("geometry_msgs/msg/Vector3", (1.0, 2.0, 3.0)),
        ("geometry_msgs/msg/Vector3", [1, 2.5, -3]),
        ("geometry_msgs/msg/Point", (0.5, 0.25, 0.125)),
        ("geometry_msgs/msg/Quaternion", (0.0, 0.0, 0.0, 1.0)),
        ("geometry_msgs/msg/Quaternion", [0, 0, 1, 0]),
        ("geometry_msgs/msg/Pose", ((1.0, 2.0, 3.0), (0.0, 0.0, 0.0, 1.0))),
        ("geometry_msgs/msg/Pose", [[1, 2, 3], [0, 0, 0, 1]]),
        ("geometry_msgs/msg/Transform", ((1.0, 2.0, 3.0), (0.0, 0.0, 0.0, 1.0))),
    ],
)
def test_vector_and_pose_direct_paths_agree_with_the_fields(type_name: str, value: Any) -> None:
    codec = codecs.lookup(type_name)
    assert isinstance(codec, NaturalCodec)
    msg = codec.encode(value)
    assert msg == codecs.from_dict(codec.to_fields(value), type_name)
    assert type(msg).__name__ == type_name.rsplit("/", 1)[1]
    assert codec.decode(msg) == codec.decode(codecs.from_dict(codec.to_fields(value), type_name))


@pytest.mark.parametrize(
    ("type_name", "value", "message"),
    [
        ("geometry_msgs/msg/Vector3", (1.0, "2", 3.0), "Vector3.y: expected float, got str"),
        ("geometry_msgs/msg/Quaternion", (0.0, 0.0, True, 1.0), "Quaternion.z: expected float, got bool"),
        ("geometry_msgs/msg/Pose", ((1.0, 2.0), (0.0, 0.0, 0.0, 1.0)), None),
    ],
)  # fmt: skip
def test_vector_and_pose_direct_paths_refuse_what_the_fields_refuse(
    type_name: str, value: Any, message: str | None
) -> None:
    codec = codecs.lookup(type_name)
    assert isinstance(codec, NaturalCodec)
    with pytest.raises(EncodeError) as direct:
        codec.encode(value)
    with pytest.raises(EncodeError) as composed:
        codec.to_fields(value)
    assert str(direct.value) == str(composed.value)
    if message is not None:
        assert str(direct.value) == message
