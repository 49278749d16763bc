"""Checks of single values on their way into a message: numbers, bools, strings, mappings.

Part of the one validation module, ``pyconnect.codecs.field_checks``, which exports these names
too (generated code imports them from there); its containers' checks use these for each element.
Anything wrong raises ``FieldError`` naming the field path, the expected and the actual type.
"""

from __future__ import annotations

import math
import numbers
import reprlib
from collections.abc import Mapping
from typing import Any, NoReturn

import numpy as np

from pyconnect.codecs.field_path import FieldError
from pyconnect.typesys.primitives import FLOAT32_OVERFLOW, INTEGER_RANGES

# rosidl stores `byte` fields as one-byte `bytes`; dicts carry them as ints 0..255.
BYTE_VALUES = tuple(bytes((i,)) for i in range(256))
_NUMERIC = (int, float, np.integer, np.floating)
_REALS = (*_NUMERIC, numbers.Real)  # the exact types first: isinstance tries them in order
# What a list may hold for the fast conversion of a numeric sequence, by element kind; anything
# else (a bool above all: Python and array() take True as 1) goes through the element checks.
PLAIN_FLOATS = frozenset((float, int))
PLAIN_INTS = frozenset((int,))


def describe(value: object) -> str:
    """The actual type as error messages name it: ``str``, ``numpy.float32``, ``NoneType``."""
    cls = type(value)
    module = cls.__module__
    return cls.__name__ if module == "builtins" else f"{module.split('.')[0]}.{cls.__name__}"


def fail(segment: str, expected: str, value: object) -> NoReturn:
    raise FieldError(segment, f"expected {expected}, got {describe(value)}")


# -- mappings ------------------------------------------------------------------------------------
def check_mapping(value: object) -> Mapping[str, Any]:
    if isinstance(value, Mapping):
        return value
    fail("", "dict", value)


def unknown_keys(data: Mapping[str, Any], known: frozenset[str]) -> FieldError:
    extra = sorted(str(k) for k in data if k not in known)
    names = ", ".join(repr(k) for k in extra)
    fields = ", ".join(sorted(known)) or "none"
    return FieldError(
        "", f"unknown field{'s' if len(extra) > 1 else ''} {names} (fields: {fields})"
    )


# -- scalars -------------------------------------------------------------------------------------
def check_bool(value: object, segment: str) -> bool:
    if isinstance(value, bool | np.bool_):
        return bool(value)
    fail(segment, "bool", value)


def check_float(value: object, segment: str) -> float:
    """``value`` as a Python float: ints and numpy (or other) reals are converted, bools refused."""
    if value.__class__ is float:
        return value
    if isinstance(value, _REALS) and not isinstance(value, bool):
        try:
            return float(value)
        except OverflowError:  # an int beyond float64's range
            raise FieldError(segment, "expected float, got an int too large for float64") from None
    fail(segment, "float", value)


def check_float32(value: object, segment: str) -> float:
    """Like ``check_float``, and finite values must round to a finite float32 (inf and NaN pass).

    The bound is ``struct.pack("<f")``'s, so the checks and the packing agree: just above
    ``FLOAT32_MAX`` (rclpy's own default ``3.4028235e38``) passes and packs to it.
    """
    number = check_float(value, segment)
    if math.isfinite(number) and abs(number) >= FLOAT32_OVERFLOW:
        raise FieldError(segment, f"expected float32 (|x| < {FLOAT32_OVERFLOW!r}), got {number!r}")
    return number


def check_int(
    value: object, low: int, high: int, kind: str, segment: str, *, expected: str = ""
) -> int:
    """``value`` as a Python int in ``[low, high]``, the range of the ROS integer type ``kind``.

    A value of the wrong type is reported as ``expected int (kind)``, or as ``expected``.
    """
    if isinstance(value, int | np.integer) and not isinstance(value, bool):
        number = int(value)
        if low <= number <= high:
            return number
        raise FieldError(segment, f"expected {kind} in [{low}, {high}], got {number}")
    fail(segment, expected or f"int ({kind})", value)


def check_kind_int(value: Any, kind: str, segment: str) -> int:
    """``check_int`` for the ROS integer type named ``kind``; the wrong type is ``expected int``."""
    if value.__class__ is int:
        low, high = INTEGER_RANGES[kind]
        if low <= value <= high:
            return value
    low, high = INTEGER_RANGES[kind]
    return check_int(value, low, high, kind, segment, expected="int")


def check_octet(value: object, segment: str) -> int:
    """A ``byte`` field: an int 0..255 in dicts; a one-byte ``bytes`` is accepted too."""
    if isinstance(value, bytes | bytearray) and len(value) == 1:
        return value[0]
    return check_int(value, 0, 255, "byte", segment)


def check_str(value: object, bound: int | None, segment: str) -> str:
    """``value`` if it is a ``str`` of at most ``bound`` characters (``None``: unbounded),
    without NUL characters, that UTF-8 can encode (no lone surrogate)."""
    if not isinstance(value, str):
        fail(segment, "str", value)
    if bound is not None and len(value) > bound:
        raise FieldError(segment, f"expected at most {bound} characters, got {len(value)}")
    if "\0" in value:
        # rclpy's C conversion ends a string at its first NUL, and so does every C or C++
        # reader of the CDR bytes: the value would arrive cut on one path and whole on another.
        raise FieldError(
            segment,
            f"expected str without NUL characters, got {reprlib.repr(value)} "
            f"(NUL at index {value.index(chr(0))})",
        )
    if not value.isascii():
        try:
            value.encode()
        except UnicodeEncodeError as error:  # a lone surrogate: rclpy's C conversion raises
            raise FieldError(segment, f"cannot encode as UTF-8 ({error.reason})") from None
    return value


def plain_str_list(values: list[Any]) -> list[Any]:
    """A copy of a list of ``str`` without NULs or lone surrogates, for generated code's fast
    path of unbounded string sequences; raises TypeError or ValueError otherwise (``str_list``
    then names it)."""
    joined = "".join(values)  # join checks in C that every element is a str
    if "\0" in joined:
        raise ValueError("a NUL character")
    if not joined.isascii():
        joined.encode()  # UnicodeEncodeError (a ValueError) for a lone surrogate
    return values.copy()
