"""Validation of natural values on encode: numbers, ranges and tuples, with path-naming errors."""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from typing import Any

from pyconnect.errors import EncodeError, type_name_of
from pyconnect.typesys.primitives import FLOAT32_MAX, INTEGER_RANGES


def check_float(value: Any, path: str) -> float:
    """``value`` as a Python float; ints and numpy reals are accepted, bools and strings are not."""
    if type(value) is float:
        return value
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        return float(value)
    raise EncodeError(f"{path}: expected float, got {type_name_of(value)}")


def check_float32(value: Any, path: str) -> float:
    """Like ``check_float``, and finite values must fit a float32 (inf and NaN pass)."""
    number = check_float(value, path)
    if -FLOAT32_MAX <= number <= FLOAT32_MAX or not math.isfinite(number):
        return number
    raise EncodeError(f"{path}: expected float32 (|x| <= {FLOAT32_MAX:.8g}), got {number!r}")


def check_int(value: Any, kind: str, path: str) -> int:
    """``value`` as a Python int inside the range of the ROS integer type ``kind``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise EncodeError(f"{path}: expected int, got {type_name_of(value)}")
    number = int(value)
    low, high = INTEGER_RANGES[kind]
    if low <= number <= high:
        return number
    raise EncodeError(f"{path}: expected {kind} in [{low}, {high}], got {number}")


def check_sequence(value: Any, length: int, path: str, expected: str) -> tuple[Any, ...]:
    """``value`` as a tuple of exactly ``length`` items (a tuple, list or 1-D ndarray)."""
    if type(value) is tuple and len(value) == length:
        return value
    if isinstance(value, Mapping | str | bytes | bytearray) or not hasattr(value, "__len__"):
        raise EncodeError(f"{path}: expected {expected}, got {type_name_of(value)}")
    items = tuple(value)
    if len(items) != length:
        raise EncodeError(
            f"{path}: expected {expected}, got {type_name_of(value)} of length {len(items)}"
        )
    return items


def check_str(value: Any, path: str) -> str:
    """``value`` if it is a ``str``."""
    if isinstance(value, str):
        return value
    raise EncodeError(f"{path}: expected str, got {type_name_of(value)}")
