"""geometry_msgs Twist, Accel, Wrench ↔ ``((x, y, z), (x, y, z))``; encode also takes the planar
``(v, w)``, meaning ``((v, 0, 0), (0, 0, w))``. Lossless, as the other plain geometry codecs
(pyconnect.codecs.geometry)."""

from __future__ import annotations

import numbers
from collections.abc import Callable
from typing import Any

from pyconnect.codecs.base import decode_failure
from pyconnect.codecs.field_checks import check_float, check_tuple
from pyconnect.codecs.geometry import (
    GeometryCodec,
    Triple,
    checked_triple,
    message_class,
    xyz_fields,
)
from pyconnect.codecs.message_slots import CHECK_FIELDS, has_slot_layout


def _twist_builder(cls: Any, vector: Any, first: str, second: str) -> Callable[..., Any]:
    """``build(ax, ay, az, bx, by, bz)`` for Twist-like classes: slot writes when allowed."""
    if not has_slot_layout(cls, vector):
        return lambda ax, ay, az, bx, by, bz: cls(
            **{first: vector(x=ax, y=ay, z=az), second: vector(x=bx, y=by, z=bz)}
        )
    first_slot, second_slot = f"_{first}", f"_{second}"
    new = object.__new__

    def build(ax: float, ay: float, az: float, bx: float, by: float, bz: float) -> Any:  # noqa: PLR0917
        a = new(vector)
        a._check_fields = CHECK_FIELDS
        a._x = ax
        a._y = ay
        a._z = az
        b = new(vector)
        b._check_fields = CHECK_FIELDS
        b._x = bx
        b._y = by
        b._z = bz
        msg = new(cls)
        msg._check_fields = CHECK_FIELDS
        setattr(msg, first_slot, a)
        setattr(msg, second_slot, b)
        return msg

    return build


def _pair_of_triples(value: Any, path: str, first: str, second: str) -> tuple[Triple, Triple]:
    if type(value) is tuple and len(value) == 2:
        a, b = value
    else:
        a, b = check_tuple(value, 2, "((x, y, z), (x, y, z)) or (v, w)", path)
    if type(a) is tuple and type(b) is tuple:
        return checked_triple(a, f"{path}.{first}"), checked_triple(b, f"{path}.{second}")
    if isinstance(a, numbers.Real) and not hasattr(a, "__len__"):
        # The planar shorthand (v, w): forward speed and yaw rate.
        return (
            (check_float(a, f"{path}.{first}.x"), 0.0, 0.0),
            (0.0, 0.0, check_float(b, f"{path}.{second}.z")),
        )
    return checked_triple(a, f"{path}.{first}"), checked_triple(b, f"{path}.{second}")


class TwistCodec(GeometryCodec):
    """geometry_msgs/Twist ↔ ``((vx, vy, vz), (wx, wy, wz))``; encode also takes ``(v, w)``."""

    msg_type = "geometry_msgs/msg/Twist"
    _name = "Twist"
    _first, _second = "linear", "angular"

    def decode(self, msg: Any) -> tuple[Triple, Triple]:
        reader = self._readers.get(type(msg)) or self._reader(
            msg,
            tuple(f"{self._first}.{a}" for a in "xyz")
            + tuple(f"{self._second}.{a}" for a in "xyz"),
        )
        try:
            ax, ay, az, bx, by, bz = reader(msg)
        except AttributeError as error:  # free until raised: a stand-in lacking a field
            raise decode_failure(error, msg, self.msg_type) from None
        return ((ax, ay, az), (bx, by, bz))

    def to_fields(self, value: Any) -> dict[str, Any]:
        a, b = _pair_of_triples(value, self._name, self._first, self._second)
        return {self._first: xyz_fields(a), self._second: xyz_fields(b)}

    def encode(self, value: Any) -> Any:
        # A hot codec keeps a direct path: composing to_fields with the generated from_dict
        # costs about 1.5x. A value of six floats goes straight into the message slots.
        build = self._build or self._builder()
        if value.__class__ is tuple and len(value) == 2:
            a, b = value
            if a.__class__ is tuple and b.__class__ is tuple and len(a) == 3 and len(b) == 3:
                ax, ay, az = a
                bx, by, bz = b
                if (
                    ax.__class__ is float
                    and ay.__class__ is float
                    and az.__class__ is float
                    and bx.__class__ is float
                    and by.__class__ is float
                    and bz.__class__ is float
                ):
                    return build(ax, ay, az, bx, by, bz)
        (ax, ay, az), (bx, by, bz) = _pair_of_triples(value, self._name, self._first, self._second)
        return build(ax, ay, az, bx, by, bz)

    _build: Callable[..., Any] | None = None

    def _builder(self) -> Callable[..., Any]:
        vector = message_class("geometry_msgs", "Vector3")
        build = self._build = _twist_builder(self._cls(), vector, self._first, self._second)
        return build


class AccelCodec(TwistCodec):
    """geometry_msgs/Accel ↔ ``((ax, ay, az), (alpha_x, alpha_y, alpha_z))``."""

    msg_type = "geometry_msgs/msg/Accel"
    _name = "Accel"
    _class: Any = None


class WrenchCodec(TwistCodec):
    """geometry_msgs/Wrench ↔ ``((fx, fy, fz), (tx, ty, tz))``."""

    msg_type = "geometry_msgs/msg/Wrench"
    _name = "Wrench"
    _class: Any = None
    _first, _second = "force", "torque"
