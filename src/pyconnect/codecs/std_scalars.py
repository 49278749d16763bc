"""std_msgs scalars ↔ Python scalars; String ↔ ``str``; Empty ↔ ``None``; ColorRGBA ↔ 4-tuple.

All of these are lossless: the messages hold nothing but the value. Encode checks the range of
the ROS type (``Int8.data: expected int8 in [-128, 127], got 300``) and rejects bools for
numbers (and numbers for bools). ``std_msgs/Byte`` is an int in [0, 255] (rclpy holds it as a
1-byte ``bytes``); ``std_msgs/Char`` is an int in [0, 255] as in rclpy.
"""

from __future__ import annotations

import numbers
from collections.abc import Callable
from functools import partial
from typing import Any

from pyconnect.codecs.base import (
    FieldsCodec,
    check_message_type,
    checked_reader,
    decode_failure,
)
from pyconnect.codecs.field_checks import (
    check_bool,
    check_float,
    check_float32,
    check_kind_int,
    check_str,
    check_tuple,
    fail,
)
from pyconnect.errors import DecodeError, type_name_of

__all__ = [
    "BoolCodec",
    "ByteCodec",
    "ColorRGBACodec",
    "EmptyCodec",
    "FloatCodec",
    "IntCodec",
    "StringCodec",
]

_INT_TYPES = {
    "Int8": "int8",
    "Int16": "int16",
    "Int32": "int32",
    "Int64": "int64",
    "UInt8": "uint8",
    "UInt16": "uint16",
    "UInt32": "uint32",
    "UInt64": "uint64",
    "Char": "char",
}

_RGBA = ("r", "g", "b", "a")
_NUMPY_BOOL = ("bool",)  # numpy's dtype("bool") == "bool"; no numpy import for the check


class _ScalarCodec(FieldsCodec):
    """A std_msgs type of one ``data`` field: each message class is checked once to be it.

    The value's own class cannot tell: an Int64's ``data`` is an int as an Int32's is, and
    2**40 would pass for an Int32 (a set lookup, ~25 ns, where a type check per call cost more).
    """

    _checked: set[type]

    def __init__(self) -> None:
        self._checked = set()

    def _check_class(self, msg: Any) -> None:
        check_message_type(msg, self.msg_type)
        self._checked.add(msg.__class__)


class IntCodec(_ScalarCodec):
    """std_msgs Int*/UInt*/Char ↔ ``int`` with a range check."""

    lossless = True

    def __init__(self, name: str) -> None:
        super().__init__()
        self.name = name
        self.kind = _INT_TYPES[name]
        self.msg_type = f"std_msgs/msg/{name}"

    def decode(self, msg: Any) -> int:
        if msg.__class__ not in self._checked:
            self._check_class(msg)
        try:
            data = msg.data
        except AttributeError as error:  # free until raised: a Point(), a class
            raise decode_failure(error, msg, self.msg_type) from None
        if data.__class__ is int:  # rclpy's and the views' value; a class or a Float64 is not
            return data
        if isinstance(data, numbers.Integral) and not isinstance(data, bool):
            return int(data)  # a numpy integer of a stand-in
        raise DecodeError(f"{self.name}.data: expected int, got {type_name_of(data)}")

    def to_fields(self, value: Any) -> dict[str, Any]:
        return {"data": check_kind_int(value, self.kind, f"{self.name}.data")}


class FloatCodec(_ScalarCodec):
    """std_msgs Float32/Float64 ↔ ``float`` (Float32 checks the float32 range)."""

    lossless = True

    def __init__(self, name: str) -> None:
        super().__init__()
        self.name = name
        self.msg_type = f"std_msgs/msg/{name}"
        self._check = check_float32 if name == "Float32" else check_float

    def decode(self, msg: Any) -> float:
        if msg.__class__ not in self._checked:
            self._check_class(msg)
        try:
            data = msg.data
        except AttributeError as error:  # free until raised: a Point(), a class
            raise decode_failure(error, msg, self.msg_type) from None
        if data.__class__ is float:  # rclpy's and the views' value; a class or an Int32 is not
            return data
        if isinstance(data, numbers.Real) and not isinstance(data, bool):
            return float(data)  # a numpy float or an int of a stand-in
        raise DecodeError(f"{self.name}.data: expected float, got {type_name_of(data)}")

    def to_fields(self, value: Any) -> dict[str, Any]:
        return {"data": self._check(value, f"{self.name}.data")}


class BoolCodec(_ScalarCodec):
    """std_msgs/Bool ↔ ``bool``."""

    msg_type = "std_msgs/msg/Bool"
    lossless = True

    def decode(self, msg: Any) -> bool:
        if msg.__class__ not in self._checked:
            self._check_class(msg)
        try:
            data = msg.data
        except AttributeError as error:  # free until raised: a Point(), a class
            raise decode_failure(error, msg, self.msg_type) from None
        if data.__class__ is bool:  # rclpy's and the views' value; a class or an Int32 is not
            return data
        if isinstance(data, numbers.Integral) or getattr(data, "dtype", None) in _NUMPY_BOOL:
            return bool(data)  # a numpy bool or a 0/1 of a stand-in
        raise DecodeError(f"Bool.data: expected bool, got {type_name_of(data)}")

    def to_fields(self, value: Any) -> dict[str, Any]:
        return {"data": check_bool(value, "Bool.data")}


class ByteCodec(_ScalarCodec):
    """std_msgs/Byte ↔ ``int`` in [0, 255] (rclpy's 1-byte ``bytes`` is converted)."""

    msg_type = "std_msgs/msg/Byte"
    lossless = True

    def decode(self, msg: Any) -> int:
        if msg.__class__ not in self._checked:
            self._check_class(msg)
        try:
            data = msg.data
        except AttributeError as error:  # free until raised: a Point(), a class
            raise decode_failure(error, msg, self.msg_type) from None
        if data.__class__ is bytes:  # rclpy's 1-byte bytes
            return data[0]
        if data.__class__ is int:  # the views'
            return data
        if isinstance(data, bytes | bytearray) and len(data) == 1:
            return data[0]
        if isinstance(data, numbers.Integral) and not isinstance(data, bool):
            return int(data)
        raise DecodeError(f"Byte.data: expected int or 1 byte, got {type_name_of(data)}")

    def to_fields(self, value: Any) -> dict[str, Any]:
        return {"data": check_kind_int(value, "byte", "Byte.data")}


class StringCodec(_ScalarCodec):
    """std_msgs/String ↔ ``str``."""

    msg_type = "std_msgs/msg/String"
    lossless = True

    def decode(self, msg: Any) -> str:
        if msg.__class__ not in self._checked:
            self._check_class(msg)
        try:
            data = msg.data
        except AttributeError as error:  # free until raised: a Point(), a class
            raise decode_failure(error, msg, self.msg_type) from None
        # str(data) turned an Int32's 5 into "5"; .__class__ costs what str() did, type() more.
        if data.__class__ is str:
            return data
        if isinstance(data, str):
            return str(data)  # numpy.str_
        raise DecodeError(f"String.data: expected str, got {type_name_of(data)}")

    def to_fields(self, value: Any) -> dict[str, Any]:
        return {"data": check_str(value, None, "String.data")}


class EmptyCodec(FieldsCodec):
    """std_msgs/Empty ↔ ``None``."""

    msg_type = "std_msgs/msg/Empty"
    lossless = True

    def __init__(self) -> None:
        self._classes: set[type] = set()  # classes checked to be Empty (or to name no type)

    def decode(self, msg: Any) -> None:
        # Nothing to read, so nothing fails: the one codec that checks each call (~25 ns).
        if msg.__class__ not in self._classes:
            check_message_type(msg, self.msg_type)
            self._classes.add(type(msg))

    def to_fields(self, value: Any) -> dict[str, Any]:
        if value is not None:
            fail("Empty", "None", value)
        return {}


class ColorRGBACodec(FieldsCodec):
    """std_msgs/ColorRGBA ↔ ``(r, g, b, a)`` floats."""

    msg_type = "std_msgs/msg/ColorRGBA"
    lossless = True

    def __init__(self) -> None:
        self._readers: dict[type, Callable[[Any], Any]] = {}

    def decode(self, msg: Any) -> tuple[float, float, float, float]:
        reader = self._readers.get(type(msg))
        if reader is None:  # once per class: a class or another message is refused here
            reader = self._readers[type(msg)] = checked_reader(msg, self.msg_type, _RGBA)
        try:
            result: tuple[float, float, float, float] = reader(msg)
        except AttributeError as error:  # free until raised: a stand-in lacking a field
            raise decode_failure(error, msg, self.msg_type) from None
        return result

    def to_fields(self, value: Any) -> dict[str, Any]:
        r, g, b, a = check_tuple(value, 4, "(r, g, b, a)", "ColorRGBA")
        return {
            "r": check_float32(r, "ColorRGBA.r"),
            "g": check_float32(g, "ColorRGBA.g"),
            "b": check_float32(b, "ColorRGBA.b"),
            "a": check_float32(a, "ColorRGBA.a"),
        }


# Factories for the natural-codec table (it calls them with no arguments).
int8_codec = partial(IntCodec, "Int8")
int16_codec = partial(IntCodec, "Int16")
int32_codec = partial(IntCodec, "Int32")
int64_codec = partial(IntCodec, "Int64")
uint8_codec = partial(IntCodec, "UInt8")
uint16_codec = partial(IntCodec, "UInt16")
uint32_codec = partial(IntCodec, "UInt32")
uint64_codec = partial(IntCodec, "UInt64")
char_codec = partial(IntCodec, "Char")
float32_codec = partial(FloatCodec, "Float32")
float64_codec = partial(FloatCodec, "Float64")
