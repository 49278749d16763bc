"""What generated CDR encoders call at run time: checks on the slow path and variable-length parts.

The generated code packs runs of fixed-size values inline; strings, wstrings, sequences of
strings or messages, and the conversion of user values to arrays come here. Errors are
``FieldError``s that collect the field path on their way up.
"""

from __future__ import annotations

import contextlib
import struct
import sys
from array import array
from collections.abc import Callable, Mapping, Sequence
from types import MappingProxyType
from typing import Any

import numpy as np

from pyconnect.codecs.cdr_read import RunLabel
from pyconnect.codecs.field_checks import (
    bool_list,
    check_bool,
    check_float,
    check_float32,
    check_int,
    check_length,
    check_octet,
    check_str,
    describe,
    numeric_array,
    numeric_sequence,
    octet_buffer,
    plain_numbers,
    uint8_array,
    uint8_sequence,
)
from pyconnect.codecs.field_path import FieldError
from pyconnect.typesys.primitives import BYTE_NAMES, INTEGER_RANGES, STRUCT_CODES

EMPTY: Mapping[str, Any] = MappingProxyType({})
ZEROS = tuple(bytes(n) for n in range(8))
HEADER_LE = b"\x00\x01\x00\x00"
HEADER_BE = b"\x00\x00\x00\x00"
EncodeFunction = Callable[[Any, list[Any], int], int]

_NATIVE = "<" if sys.byteorder == "little" else ">"
_ORDER = {"<": "<", ">": ">", "=": _NATIVE, "|": "<"}


def check_scalar(kind: str, value: Any, segment: str) -> Any:
    """Check one value of a run on the slow path, converting numpy scalars and one-byte bytes."""
    if kind == "bool":
        return check_bool(value, segment)
    if kind == "float64":
        return check_float(value, segment)
    if kind == "float32":
        return check_float32(value, segment)
    if kind == "byte":
        return check_octet(value, segment)
    low, high = INTEGER_RANGES[kind]
    return check_int(value, low, high, kind, segment)


def slow_pack(packer: struct.Struct, label: RunLabel, values: Sequence[Any]) -> bytes:
    """Pack a run whose fast ``pack`` failed: check each value, raise naming the bad one."""
    converted = [check_scalar(kind, value, segment) for (segment, kind, _), value in
                 zip(label, values, strict=True)]  # fmt: skip
    try:
        return packer.pack(*converted)
    except (struct.error, OverflowError, TypeError) as error:
        raise _pack_failure(packer.format[0], label, converted, error) from None


def _pack_failure(
    order: str, label: RunLabel, values: Sequence[Any], error: Exception
) -> FieldError:
    """The error for a run that passed its checks and still did not pack, naming the value that
    does not pack on its own: the run packs several fields, and the first may be innocent."""
    for (segment, kind, _), value in zip(label, values, strict=True):
        try:
            struct.pack(order + STRUCT_CODES[kind], value)
        except (struct.error, OverflowError, TypeError) as own_error:
            return FieldError(segment, f"cannot encode ({own_error})")
    return FieldError(label[0][0], f"cannot encode ({error})")


def encode_failure(error: BaseException, label: str, data: Any) -> FieldError:
    """Turn whatever an encoder's fast path raised into a ``FieldError`` naming the field."""
    if not isinstance(data, Mapping):
        return FieldError("", f"expected dict, got {describe(data)}")
    return FieldError(label, f"cannot encode ({describe(error)}: {error})")


def utf8z(value: Any, bound: int | None) -> bytes:
    """A string's UTF-8 bytes and the NUL terminator CDR writes after them."""
    if (
        value.__class__ is not str
        or (bound is not None and len(value) > bound)
        or "\0" in value  # C readers would end the string there (check_str says so)
    ):
        value = check_str(value, bound, "")
    try:
        return value.encode() + b"\0"  # type: ignore[no-any-return]
    except UnicodeEncodeError as error:
        raise FieldError("", f"cannot encode as UTF-8 ({error.reason})") from None


def _wstring_bytes(value: Any, u32: struct.Struct, bound: int | None) -> tuple[int, bytes]:
    text = check_str(value, bound, "")
    try:
        raw = text.encode("utf-16-le")
    except UnicodeEncodeError as error:
        raise FieldError("", f"cannot encode as UTF-16 ({error.reason})") from None
    units = np.frombuffer(raw, dtype="<u2").astype(u32.format[0] + "u4")
    return len(units), units.tobytes()


def write_wstring(
    value: Any, out: list[Any], pos: int, u32: struct.Struct, bound: int | None
) -> int:
    count, raw = _wstring_bytes(value, u32, bound)
    pad = -pos & 3
    if pad:
        out.append(ZEROS[pad])
    out.append(u32.pack(count))
    out.append(raw)
    return pos + pad + 4 + len(raw)


def _as_list(value: Any) -> Sequence[Any]:
    if isinstance(value, list | tuple):
        return value
    if isinstance(value, np.ndarray) and value.ndim == 1:
        return value.tolist()  # type: ignore[no-any-return]
    raise FieldError("", f"expected list, got {describe(value)}")


def _sequence_start(  # noqa: PLR0917 (mirrors the writers' positional signature)
    value: Any, out: list[Any], pos: int, u32: struct.Struct, size: int | None, fixed: bool
) -> tuple[Sequence[Any], int]:
    """The checked elements, and the position after the count a sequence starts with."""
    values = _as_list(value)
    check_length(values, size, fixed, "")
    if not fixed:
        pad = -pos & 3
        if pad:
            out.append(ZEROS[pad])
        out.append(u32.pack(len(values)))
        pos += pad + 4
    return values, pos


def write_strings(  # noqa: PLR0917 (generated code calls it positionally)
    value: Any,
    out: list[Any],
    pos: int,
    u32: struct.Struct,
    size: int | None,
    fixed: bool,
    string_bound: int | None,
    wide: bool,
) -> int:
    values, pos = _sequence_start(value, out, pos, u32, size, fixed)
    for index, text in enumerate(values):
        try:
            if wide:
                pos = write_wstring(text, out, pos, u32, string_bound)
                continue
            raw = utf8z(text, string_bound)
        except FieldError as error:
            raise error.within(f"[{index}]") from None
        pad = -pos & 3
        if pad:
            out.append(ZEROS[pad])
        out.append(u32.pack(len(raw)))
        out.append(raw)
        pos += pad + 4 + len(raw)
    return pos


def write_messages(  # noqa: PLR0917 (generated code calls it positionally)
    value: Any,
    out: list[Any],
    pos: int,
    u32: struct.Struct,
    encode: EncodeFunction,
    size: int | None,
    fixed: bool,
) -> int:
    values, pos = _sequence_start(value, out, pos, u32, size, fixed)
    for index, item in enumerate(values):
        try:
            pos = encode(item, out, pos)
        except FieldError as error:
            raise error.within(f"[{index}]") from None
    return pos


def _byte_buffer(value: Any) -> memoryview | None:
    """A zero-copy byte view of bytes-like values and uint8 ndarrays, else None."""
    if isinstance(value, bytes | bytearray):
        return memoryview(value)
    if isinstance(value, memoryview) and value.format == "B" and value.ndim == 1:
        # A strided view cannot go into the output as it is (join takes contiguous buffers).
        return value if value.c_contiguous else None
    if (
        isinstance(value, np.ndarray)
        and value.dtype == np.uint8
        and value.ndim == 1
        and value.flags.c_contiguous
    ):
        return value.data
    return None


def encode_array(
    value: Any, dtype: np.dtype[Any], kind: str, size: int | None, fixed: bool
) -> tuple[Any, int]:
    """A numeric array or sequence as bytes in ``dtype``'s byte order, and its element count.

    ``bytes``/``bytearray`` and ndarrays of exactly ``dtype`` are not copied here; lists are
    checked element by element (the error names the first bad one).
    """
    if kind in BYTE_NAMES:
        view = _byte_buffer(value)
        if view is not None:
            check_length(view, size, fixed, "")
            return view, len(view)
        if kind == "byte":  # rosidl's one-byte bytes are a byte[]'s elements too
            converted: Any = octet_buffer(value, size, fixed, "")
        elif fixed:
            converted = uint8_array(value, size or 0, "")
        else:
            converted = uint8_sequence(value, size, "")
        return converted, len(converted)
    if value.__class__ is list or value.__class__ is tuple:
        # struct checks every element's type and range but takes bools as numbers: lists of
        # anything but plain ints (and floats, for float kinds), and whatever struct rejects, are
        # checked again below, which names the bad element.
        count = len(value)
        if (size is None or (count == size if fixed else count <= size)) and plain_numbers(
            value, kind
        ):
            with contextlib.suppress(struct.error, OverflowError, TypeError):
                return struct.pack(
                    f"{_ORDER[dtype.byteorder]}{count}{STRUCT_CODES[kind]}", *value
                ), count
    if (
        value.__class__ is array
        and value.typecode == STRUCT_CODES[kind]
        and value.itemsize == dtype.itemsize
        and _ORDER[dtype.byteorder] == _NATIVE
    ):
        # rclpy's storage (and JointState's columns): typed, so it holds no bools; not copied.
        check_length(value, size, fixed, "")
        return memoryview(value).cast("B"), len(value)
    if (
        isinstance(value, np.ndarray)
        and value.dtype == dtype
        and value.ndim == 1
        and value.flags.c_contiguous
    ):
        check_length(value, size, fixed, "")
        return value.data.cast("B"), len(value)
    if fixed:
        result = numeric_array(value, STRUCT_CODES[kind], dtype.name, kind, size or 0, "")
    else:
        result = np.frombuffer(numeric_sequence(value, STRUCT_CODES[kind], kind, size, ""),
                               dtype=dtype.newbyteorder("="))  # fmt: skip
    count = len(result)
    if result.dtype != dtype:
        result = result.astype(dtype)
    return np.ascontiguousarray(result).data.cast("B"), count


def encode_bools(
    value: Any, dtype: np.dtype[Any], kind: str, size: int | None, fixed: bool
) -> tuple[bytes, int]:
    del dtype, kind
    values = bool_list(value, size, fixed, "")
    return bytes(values), len(values)
