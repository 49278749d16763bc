"""The one validation module: checks and conversions of values on their way into a message.

Generated code (dict and wire encoders) tests the common case inline (``type(v) is float``) and
calls these only for anything else; natural codecs call them for every value they take. Numpy
scalars and arrays are converted; anything wrong raises ``FieldError`` (an ``EncodeError``)
naming the field path, the expected and the actual type: generated code passes the field's
segment (``.data``) and adds the rest of the path as the error passes up, natural codecs pass the
whole path (``Twist.linear.x``). Bools are refused wherever numbers go, and numbers where bools go.
"""

from __future__ import annotations

import math
import numbers
import reprlib
from array import array
from collections.abc import Callable, Mapping, Sequence
from typing import Any, NoReturn

import numpy as np

from pyconnect.codecs.field_path import FieldError
from pyconnect.typesys.primitives import FLOAT32_MAX, INTEGER_NAMES, INTEGER_RANGES

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
    """Like ``check_float``, and finite values must fit a float32 (inf and NaN pass)."""
    number = check_float(value, segment)
    if math.isfinite(number) and abs(number) > FLOAT32_MAX:
        raise FieldError(segment, f"expected float32 (|x| <= {FLOAT32_MAX:.8g}), got {number!r}")
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


# -- containers ----------------------------------------------------------------------------------
def check_tuple(value: Any, length: int, expected: str, segment: str) -> tuple[Any, ...]:
    """``value`` as a tuple of exactly ``length`` items (a tuple, list or 1-D ndarray).

    ``expected`` names the shape in the error: ``Twist: expected ((x, y, z), (x, y, z)), got int``.
    """
    if value.__class__ is tuple and len(value) == length:
        return value
    if isinstance(value, Mapping | str | bytes | bytearray) or not hasattr(value, "__len__"):
        fail(segment, expected, value)
    items = tuple(value)
    if len(items) != length:
        raise FieldError(
            segment, f"expected {expected}, got {describe(value)} of length {len(items)}"
        )
    return items


def check_length(value: Any, size: int | None, fixed: bool, segment: str) -> None:
    if size is None:
        return
    length = len(value)
    if fixed and length != size:
        raise FieldError(segment, f"expected exactly {size} elements, got {length}")
    if not fixed and length > size:
        raise FieldError(segment, f"expected at most {size} elements, got {length}")


def _check_sequence(value: object, segment: str) -> Sequence[Any] | np.ndarray:
    if isinstance(value, np.ndarray):
        if value.ndim != 1:
            fail(segment, "a one-dimensional sequence", value)
        return value
    if isinstance(value, str | bytes | bytearray | Mapping) or not isinstance(value, Sequence):
        if isinstance(value, array | memoryview):
            return value
        fail(segment, "list", value)
    return value


def _element_error(values: Any, check: Callable[[object, str], object], segment: str) -> NoReturn:
    # Only reached when the fast conversion failed: find the element that made it fail.
    for index, element in enumerate(values):
        try:
            check(element, "")
        except FieldError as error:
            raise error.within(f"[{index}]").within(segment) from None
    raise FieldError(segment, "could not convert the sequence")


def _checked_elements(
    values: Any, check: Callable[[object, str], object], segment: str
) -> list[Any]:
    """Every element through ``check`` (converting numpy scalars), naming the first bad one."""
    checked = []
    for index, element in enumerate(values):
        try:
            checked.append(check(element, ""))
        except FieldError as error:
            raise error.within(f"[{index}]").within(segment) from None
    return checked


def _scalar_check(kind: str) -> Callable[[object, str], object]:
    if kind == "float64":
        return check_float
    if kind == "float32":
        return check_float32
    if kind == "bool":
        return check_bool
    low, high = INTEGER_RANGES[kind]
    return lambda value, segment: check_int(value, low, high, kind, segment)


def _to_array(
    values: Sequence[Any] | np.ndarray, typecode: str, kind: str, segment: str
) -> array[Any]:
    """Convert checked values to ``array(typecode)``, naming the first element that does not fit."""
    if isinstance(values, np.ndarray):
        if values.dtype.kind not in "iuf":
            raise FieldError(segment, f"expected an array of {kind}, got dtype {values.dtype}")
        with np.errstate(invalid="ignore", over="ignore"):  # what does not fit is named below
            cast = values.astype(np.dtype(typecode), copy=False)
        if (values.dtype.kind in "iu" and not np.array_equal(cast, values)) or (
            kind in _INTEGER_KINDS and values.dtype.kind == "f"
        ):
            _element_error(values.tolist(), _scalar_check(kind), segment)
        converted = array(typecode)
        converted.frombytes(np.ascontiguousarray(cast).tobytes())
    else:
        if not isinstance(values, array) and not plain_numbers(values, kind):
            values = _checked_elements(values, _scalar_check(kind), segment)
        try:
            converted = array(typecode, values)
        except (TypeError, OverflowError, ValueError):
            _element_error(values, _scalar_check(kind), segment)
    if kind == "float32" and converted:
        # array('f') silently turns out-of-range doubles into inf; rosidl rejects them.
        for index in np.flatnonzero(np.isinf(np.frombuffer(converted, np.float32))).tolist():
            try:
                check_float32(values[index], "")
            except FieldError as error:
                raise error.within(f"[{index}]").within(segment) from None
    return converted


_INTEGER_KINDS = frozenset(INTEGER_NAMES)


def plain_numbers(values: Sequence[Any], kind: str) -> bool:
    """Whether ``values`` holds only plain ints (or floats, for a float ``kind``): no bools."""
    return (PLAIN_INTS if kind in _INTEGER_KINDS else PLAIN_FLOATS).issuperset(map(type, values))


def numeric_sequence(
    value: object, typecode: str, kind: str, size: int | None, segment: str
) -> array[Any]:
    """An ``array.array`` for a numeric ``sequence<...>`` field (the rosidl storage)."""
    values = _check_sequence(value, segment)
    check_length(values, size, False, segment)
    return _to_array(values, typecode, kind, segment)


def numeric_array(  # noqa: PLR0917 - called positionally by generated code
    value: object, typecode: str, dtype: str, kind: str, size: int, segment: str
) -> np.ndarray:
    """A fresh numpy array of exactly ``size`` elements for a fixed-size numeric array field."""
    values = _check_sequence(value, segment)
    check_length(values, size, True, segment)
    converted = _to_array(values, typecode, kind, segment)
    return np.array(np.frombuffer(converted, dtype=dtype))


def bool_list(value: object, size: int | None, fixed: bool, segment: str) -> list[bool]:
    values = _check_sequence(value, segment)
    check_length(values, size, fixed, segment)
    result = []
    for index, element in enumerate(values):
        if type(element) is bool:
            result.append(element)
            continue
        try:
            result.append(check_bool(element, ""))
        except FieldError as error:
            raise error.within(f"[{index}]").within(segment) from None
    return result


def str_list(
    value: object, bound: int | None, size: int | None, fixed: bool, segment: str
) -> list[str]:
    values = _check_sequence(value, segment)
    check_length(values, size, fixed, segment)
    for index, element in enumerate(values):
        if (
            type(element) is not str
            or (bound is not None and len(element) > bound)
            or "\0" in element
            or not element.isascii()
        ):
            try:
                check_str(element, bound, "")
            except FieldError as error:
                raise error.within(f"[{index}]").within(segment) from None
    return list(values)


def _as_byte_buffer(value: object, segment: str) -> bytes | bytearray | memoryview | np.ndarray:
    if isinstance(value, bytes | bytearray):
        return value
    if isinstance(value, memoryview):
        return value.cast("B") if value.format != "B" or value.ndim != 1 else value
    if isinstance(value, np.ndarray):
        if value.dtype != np.uint8:
            # Only integer arrays have a meaningful min/max (object or str ones raise).
            integral = value.dtype.kind in "iu"
            out_of_range = integral and value.size > 0 and (value.min() < 0 or value.max() > 255)
            if not integral or out_of_range:
                raise FieldError(
                    segment, f"expected bytes or uint8 values, got dtype {value.dtype}"
                )
            value = value.astype(np.uint8)
        return np.ascontiguousarray(value).reshape(-1)
    if isinstance(value, array) and value.typecode == "B":
        return memoryview(value)
    if isinstance(value, Sequence) and not isinstance(value, str):
        if not PLAIN_INTS.issuperset(map(type, value)):
            value = _checked_elements(value, _scalar_check("uint8"), segment)
        try:
            return bytes(value)
        except (TypeError, ValueError):
            _element_error(value, _scalar_check("uint8"), segment)
    fail(segment, "bytes", value)


def uint8_sequence(value: object, size: int | None, segment: str) -> array[int]:
    """An ``array('B')`` for ``uint8[]``/``char[]``: one copy from bytes or a uint8 ndarray."""
    buffer = _as_byte_buffer(value, segment)
    check_length(buffer, size, False, segment)
    result = array("B")
    result.frombytes(buffer)  # type: ignore[arg-type]  # ndarray is a buffer
    return result


def uint8_array(value: object, size: int, segment: str) -> np.ndarray:
    buffer = _as_byte_buffer(value, segment)
    check_length(buffer, size, True, segment)
    return np.array(np.frombuffer(buffer, dtype=np.uint8))


def octet_list(value: object, size: int | None, fixed: bool, segment: str) -> list[bytes]:
    """``byte[]``: rosidl keeps a list of one-byte ``bytes``."""
    buffer = bytes(_as_byte_buffer(value, segment))
    check_length(buffer, size, fixed, segment)
    return [BYTE_VALUES[b] for b in buffer]


def message_list(
    value: object,
    convert: Callable[[Mapping[str, Any]], Any],
    size: int | None,
    fixed: bool,
    segment: str,
) -> list[Any]:
    values = _check_sequence(value, segment)
    check_length(values, size, fixed, segment)
    result = []
    for index, element in enumerate(values):
        try:
            result.append(convert(element))
        except FieldError as error:
            raise error.within(f"[{index}]").within(segment) from None
    return result
