"""geometry_msgs ``*Stamped`` messages ↔ the natural value of their inner field.

The header is dropped (``stamped=True`` keeps stamp and frame); TransformStamped also drops
``child_frame_id``. Their ``lossless`` is False.
"""

from __future__ import annotations

from typing import Any

from pyconnect.codecs.base import FieldsCodec, decode_failure
from pyconnect.codecs.field_path import rerooted
from pyconnect.codecs.geometry import (
    PointCodec,
    PoseCodec,
    QuaternionCodec,
    TransformCodec,
    Vector3Codec,
)
from pyconnect.codecs.geometry_arrays import PolygonCodec
from pyconnect.codecs.geometry_twist import AccelCodec, TwistCodec, WrenchCodec
from pyconnect.errors import DecodeError, EncodeError


class StampedCodec(FieldsCodec):
    """A ``*Stamped`` message ↔ the natural value of its inner field (the header is dropped)."""

    lossless = False

    def __init__(self, name: str, field: str, inner: Any) -> None:
        self.name = name
        self.msg_type = f"geometry_msgs/msg/{name}"
        self.field = field
        self.inner = inner

    def decode(self, msg: Any) -> Any:
        try:
            return self.inner.decode(getattr(msg, self.field))
        except (AttributeError, DecodeError) as error:  # free until raised: a class, a Point()
            raise decode_failure(error, msg, self.msg_type) from None

    def to_fields(self, value: Any) -> dict[str, Any]:
        try:
            return {self.field: self.inner.to_fields(value)}
        except EncodeError as error:  # named from the inner type: PoseStamped.pose.orientation
            inner = self.inner.msg_type.rsplit("/", 1)[-1]
            raise rerooted(error, inner, f"{self.name}.{self.field}") from None


def point_stamped_codec() -> StampedCodec:
    return StampedCodec("PointStamped", "point", PointCodec())


def vector3_stamped_codec() -> StampedCodec:
    return StampedCodec("Vector3Stamped", "vector", Vector3Codec())


def quaternion_stamped_codec() -> StampedCodec:
    return StampedCodec("QuaternionStamped", "quaternion", QuaternionCodec())


def pose_stamped_codec() -> StampedCodec:
    return StampedCodec("PoseStamped", "pose", PoseCodec())


def transform_stamped_codec() -> StampedCodec:
    return StampedCodec("TransformStamped", "transform", TransformCodec())


def twist_stamped_codec() -> StampedCodec:
    return StampedCodec("TwistStamped", "twist", TwistCodec())


def accel_stamped_codec() -> StampedCodec:
    return StampedCodec("AccelStamped", "accel", AccelCodec())


def wrench_stamped_codec() -> StampedCodec:
    return StampedCodec("WrenchStamped", "wrench", WrenchCodec())


def polygon_stamped_codec() -> StampedCodec:
    return StampedCodec("PolygonStamped", "polygon", PolygonCodec())
