"""geometry_msgs ↔ tuples: vectors ``(x, y, z)``, poses ``((x, y, z), (qx, qy, qz, qw))``.

- Vector3, Point, Point32 → ``(x, y, z)``; Quaternion → ``(x, y, z, w)``; Pose2D → ``(x, y, theta)``
- Pose, Transform → ``((x, y, z), (qx, qy, qz, qw))``
- Twist, Accel, Wrench: ``geometry_twist``; Polygon, PoseArray, nav_msgs/Path:
  ``geometry_arrays``; the ``*Stamped`` variants: ``geometry_stamped``.

The plain types are lossless (Polygon and Point32 for received messages, whose values are
float32; an in-process Point32 built from a double keeps it until serialised, and the float32
array rounds it). The stamped ones drop the header (use ``stamped=True`` to keep
stamp and frame); TransformStamped also drops ``child_frame_id``; Path drops the header of
every pose. Their ``lossless`` is False.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from pyconnect.codecs.base import FieldsCodec, check_message_type, decode_failure
from pyconnect.codecs.field_checks import check_float, check_float32, check_tuple
from pyconnect.codecs.message_slots import CHECK_FIELDS, has_slot_layout, path_reader

Triple = tuple[float, float, float]
Quad = tuple[float, float, float, float]
PoseValue = tuple[Triple, Quad]


def message_class(module: str, name: str) -> Any:
    import importlib

    return getattr(importlib.import_module(f"{module}.msg"), name)


def _xyz_builder(cls: Any) -> Callable[[Triple], Any]:
    """``build((x, y, z))``: a new ``cls`` (Vector3, Point) holding three checked floats."""
    if not has_slot_layout(cls):
        return lambda v: cls(x=v[0], y=v[1], z=v[2])
    new = object.__new__

    def build(value: Triple) -> Any:
        msg = new(cls)
        msg._check_fields = CHECK_FIELDS
        msg._x, msg._y, msg._z = value
        return msg

    return build


def _xyzw_builder(cls: Any) -> Callable[[Quad], Any]:
    """``build((x, y, z, w))``: a new Quaternion holding four checked floats."""
    if not has_slot_layout(cls):
        return lambda v: cls(x=v[0], y=v[1], z=v[2], w=v[3])
    new = object.__new__

    def build(value: Quad) -> Any:
        msg = new(cls)
        msg._check_fields = CHECK_FIELDS
        msg._x, msg._y, msg._z, msg._w = value
        return msg

    return build


def checked_triple(value: Any, path: str) -> Triple:
    if type(value) is tuple and len(value) == 3:
        x, y, z = value
        if type(x) is float and type(y) is float and type(z) is float:
            return value
    else:
        x, y, z = check_tuple(value, 3, "(x, y, z)", path)
    return (check_float(x, f"{path}.x"), check_float(y, f"{path}.y"), check_float(z, f"{path}.z"))


def _triple32(value: Any, path: str) -> Triple:
    x, y, z = check_tuple(value, 3, "(x, y, z)", path)
    return (
        check_float32(x, f"{path}.x"),
        check_float32(y, f"{path}.y"),
        check_float32(z, f"{path}.z"),
    )


def _quad(value: Any, path: str) -> Quad:
    if type(value) is tuple and len(value) == 4:
        x, y, z, w = value
        if type(x) is float and type(y) is float and type(z) is float and type(w) is float:
            return value
    else:
        x, y, z, w = check_tuple(value, 4, "(x, y, z, w)", path)
    return (
        check_float(x, f"{path}.x"),
        check_float(y, f"{path}.y"),
        check_float(z, f"{path}.z"),
        check_float(w, f"{path}.w"),
    )


def xyz_fields(value: Triple) -> dict[str, float]:
    return {"x": value[0], "y": value[1], "z": value[2]}


def xyzw_fields(value: Quad) -> dict[str, float]:
    return {"x": value[0], "y": value[1], "z": value[2], "w": value[3]}


class GeometryCodec(FieldsCodec):
    """Shared plumbing: readers of the fields by message class; the message class, on demand."""

    msg_type = ""
    lossless = True
    _module = "geometry_msgs"
    _name = ""
    _class: Any = None

    def __init__(self) -> None:
        # Per message class (rclpy's, a wire view's, rosbags'): how to read the fields.
        self._readers: dict[type, Callable[[Any], Any]] = {}

    def _reader(self, msg: Any, paths: tuple[str, ...]) -> Callable[[Any], Any]:
        # Once per class, so the checks cost decode nothing: a message class or a message of
        # another type (a Point for a Twist) is refused here, never cached.
        check_message_type(msg, self.msg_type)
        reader = self._readers[type(msg)] = path_reader(msg, paths)
        return reader

    def _cls(self) -> Any:
        cls = type(self)._class
        if cls is None:
            cls = type(self)._class = message_class(self._module, self._name)
        return cls

    _build: Callable[..., Any] | None = None


class Vector3Codec(GeometryCodec):
    """geometry_msgs/Vector3 ↔ ``(x, y, z)``."""

    msg_type = "geometry_msgs/msg/Vector3"
    _name = "Vector3"

    def decode(self, msg: Any) -> Triple:
        reader = self._readers.get(type(msg)) or self._reader(msg, ("x", "y", "z"))
        try:
            result: Triple = reader(msg)
        except AttributeError as error:  # free until raised: a stand-in lacking a field
            raise decode_failure(error, msg, self.msg_type) from None
        return result

    def to_fields(self, value: Any) -> dict[str, Any]:
        return xyz_fields(checked_triple(value, self._name))

    def encode(self, value: Any) -> Any:
        # A hot codec keeps a direct path (composing costs it 2x): checked floats into slots.
        build = self._build
        if build is None:
            build = self._build = _xyz_builder(self._cls())
        return build(checked_triple(value, self._name))


class PointCodec(Vector3Codec):
    """geometry_msgs/Point ↔ ``(x, y, z)``."""

    msg_type = "geometry_msgs/msg/Point"
    _name = "Point"
    _class: Any = None


class Point32Codec(Vector3Codec):
    """geometry_msgs/Point32 ↔ ``(x, y, z)`` (float32 range checked)."""

    msg_type = "geometry_msgs/msg/Point32"
    _name = "Point32"
    _class: Any = None

    def to_fields(self, value: Any) -> dict[str, Any]:
        return xyz_fields(_triple32(value, self._name))

    encode = FieldsCodec.encode  # float32 values: the generated code rounds them as rclpy does


class QuaternionCodec(GeometryCodec):
    """geometry_msgs/Quaternion ↔ ``(x, y, z, w)``."""

    msg_type = "geometry_msgs/msg/Quaternion"
    _name = "Quaternion"

    def decode(self, msg: Any) -> Quad:
        reader = self._readers.get(type(msg)) or self._reader(msg, ("x", "y", "z", "w"))
        try:
            result: Quad = reader(msg)
        except AttributeError as error:  # free until raised: a stand-in lacking a field
            raise decode_failure(error, msg, self.msg_type) from None
        return result

    def to_fields(self, value: Any) -> dict[str, Any]:
        return xyzw_fields(_quad(value, self._name))

    def encode(self, value: Any) -> Any:
        build = self._build
        if build is None:
            build = self._build = _xyzw_builder(self._cls())
        return build(_quad(value, self._name))


class Pose2DCodec(GeometryCodec):
    """geometry_msgs/Pose2D ↔ ``(x, y, theta)``."""

    msg_type = "geometry_msgs/msg/Pose2D"
    _name = "Pose2D"

    def decode(self, msg: Any) -> Triple:
        reader = self._readers.get(type(msg)) or self._reader(msg, ("x", "y", "theta"))
        try:
            result: Triple = reader(msg)
        except AttributeError as error:  # free until raised: a stand-in lacking a field
            raise decode_failure(error, msg, self.msg_type) from None
        return result

    def to_fields(self, value: Any) -> dict[str, Any]:
        x, y, theta = check_tuple(value, 3, "(x, y, theta)", "Pose2D")
        return {
            "x": check_float(x, "Pose2D.x"),
            "y": check_float(y, "Pose2D.y"),
            "theta": check_float(theta, "Pose2D.theta"),
        }


def pose_parts(value: Any, path: str, first: str, second: str) -> tuple[Triple, Quad]:
    position, orientation = check_tuple(value, 2, "((x, y, z), (qx, qy, qz, qw))", path)
    return checked_triple(position, f"{path}.{first}"), _quad(orientation, f"{path}.{second}")


class PoseCodec(GeometryCodec):
    """geometry_msgs/Pose ↔ ``((x, y, z), (qx, qy, qz, qw))``."""

    msg_type = "geometry_msgs/msg/Pose"
    _name = "Pose"
    _first, _second = "position", "orientation"

    def decode(self, msg: Any) -> PoseValue:
        reader = self._readers.get(type(msg)) or self._reader(
            msg,
            tuple(f"{self._first}.{a}" for a in "xyz")
            + tuple(f"{self._second}.{a}" for a in "xyzw"),
        )
        try:
            x, y, z, qx, qy, qz, qw = reader(msg)
        except AttributeError as error:  # free until raised: a stand-in lacking a field
            raise decode_failure(error, msg, self.msg_type) from None
        return ((x, y, z), (qx, qy, qz, qw))

    def to_fields(self, value: Any) -> dict[str, Any]:
        p, q = pose_parts(value, self._name, self._first, self._second)
        return {self._first: xyz_fields(p), self._second: xyzw_fields(q)}

    _vector_name = "Point"

    def encode(self, value: Any) -> Any:
        build = self._build
        if build is None:
            build = self._build = self._pose_builder()
        return build(*pose_parts(value, self._name, self._first, self._second))

    def _pose_builder(self) -> Callable[[Triple, Quad], Any]:
        cls = self._cls()
        vector = message_class(self._module, self._vector_name)
        quaternion = message_class(self._module, "Quaternion")
        build_vector = _xyz_builder(vector)
        build_quaternion = _xyzw_builder(quaternion)
        first, second = self._first, self._second
        if not has_slot_layout(cls):
            return lambda p, q: cls(**{first: build_vector(p), second: build_quaternion(q)})
        first_slot, second_slot = f"_{first}", f"_{second}"
        new = object.__new__

        def build(p: Triple, q: Quad) -> Any:
            msg = new(cls)
            msg._check_fields = CHECK_FIELDS
            setattr(msg, first_slot, build_vector(p))
            setattr(msg, second_slot, build_quaternion(q))
            return msg

        return build


class TransformCodec(PoseCodec):
    """geometry_msgs/Transform ↔ ``((x, y, z), (qx, qy, qz, qw))``."""

    msg_type = "geometry_msgs/msg/Transform"
    _name = "Transform"
    _class: Any = None
    _first, _second = "translation", "rotation"
    _vector_name = "Vector3"
