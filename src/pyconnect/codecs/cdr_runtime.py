"""What generated CDR wire codecs call at run time: path-carrying errors and variable-length parts.

The generated code handles runs of fixed-size values and numeric arrays inline; strings,
wstrings, sequences of strings or messages, and the conversion of user values to arrays come
here. Positions (``pos``) count from the end of the 4-byte encapsulation header, where CDR
alignment starts; ``lim`` is the length of that body.
"""

from __future__ import annotations

import contextlib
import struct
import sys
from collections.abc import Callable, Mapping, Sequence
from types import MappingProxyType
from typing import Any

import numpy as np

from pyconnect.codecs.field_checks import (
    FieldError,
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
    uint8_array,
    uint8_sequence,
)
from pyconnect.errors import DecodeError
from pyconnect.typesys.primitives import BYTE_NAMES, INTEGER_RANGES, PRIMITIVE_SIZES, STRUCT_CODES

EMPTY: Mapping[str, Any] = MappingProxyType({})
ZEROS = tuple(bytes(n) for n in range(8))
HEADER_LE = b"\x00\x01\x00\x00"
HEADER_BE = b"\x00\x00\x00\x00"
# (segment, primitive kind, end offset in the run) for each value of a run of fixed-size values.
RunLabel = tuple[tuple[str, str, int], ...]
DecodeFunction = Callable[[memoryview, int, int], tuple[Any, int]]
EncodeFunction = Callable[[Any, list[Any], int], int]

_ORDER = {"<": "<", ">": ">", "=": "<" if sys.byteorder == "little" else ">", "|": "<"}


class WireDecodeError(DecodeError):
    """A ``DecodeError`` that collects its field path while it travels up the generated code."""

    def __init__(self, detail: str) -> None:
        super().__init__(detail)
        self.detail = detail
        self.segments: list[str] = []

    def within(self, segment: str) -> WireDecodeError:
        """Prefix the path with the field (``.header``) or index (``[3]``) it was raised in."""
        if segment and isinstance(segment, str):
            self.segments.append(segment)
        return self

    @property
    def path(self) -> str:
        return "".join(reversed(self.segments))

    def __str__(self) -> str:
        return f"{self.path}: {self.detail}"


# Helpers with many parameters are called positionally by the generated code, where keyword
# arguments would only cost time: they carry `noqa: PLR0917`.


# -- decoding ----------------------------------------------------------------------------------
def too_long(count: int, itemsize: int, left: int) -> WireDecodeError:
    """A length prefix that asks for more bytes than the buffer has (nothing is allocated)."""
    size = f"length {count}" if itemsize == 1 else f"length {count} x {itemsize} bytes"
    return WireDecodeError(f"{size} exceeds the {max(left, 0)} bytes left")


def over_bound(count: int, bound: int) -> WireDecodeError:
    return WireDecodeError(f"length {count} exceeds the bound {bound}")


def decode_failure(
    error: BaseException, label: str | RunLabel, pos: int, lim: int
) -> WireDecodeError:
    """Turn whatever the fast path raised into a ``WireDecodeError`` naming the field."""
    left = lim - pos
    if isinstance(label, tuple):
        for segment, kind, end in label:
            if end > left:
                size = PRIMITIVE_SIZES[kind]
                detail = f"truncated: {kind} at offset {pos + 4 + end - size} needs "
                detail += f"{size} bytes, {max(0, left - end + size)} left"
                return WireDecodeError(detail).within(segment)
        if not label:  # an empty message's run is its one padding byte
            return WireDecodeError(f"truncated at offset {pos + 4} ({max(left, 0)} bytes left)")
        return WireDecodeError(f"malformed ({describe(error)}: {error})").within(label[0][0])
    if isinstance(error, UnicodeDecodeError):
        detail = f"invalid {error.encoding.upper()} ({error.reason} at byte {error.start})"
    elif isinstance(error, struct.error):
        detail = f"truncated at offset {pos + 4} ({max(left, 0)} bytes left)"
    else:
        detail = f"malformed ({describe(error)}: {error})"
    return WireDecodeError(detail).within(label)


def read_bools(mv: memoryview, pos: int, count: int) -> list[bool]:
    return [byte != 0 for byte in mv[pos : pos + count]]


def read_wstring(
    mv: memoryview, pos: int, lim: int, u32: struct.Struct, bound: int | None
) -> tuple[str, int]:
    """A wstring as Fast DDS writes it: uint32 count of UTF-16 units, each as a 4-byte wchar_t."""
    pos = (pos + 3) & -4
    (count,) = u32.unpack_from(mv, pos)
    pos += 4
    if count * 4 > lim - pos:
        raise too_long(count, 4, lim - pos)
    units = np.frombuffer(mv, dtype=u32.format[0] + "u4", count=count, offset=pos)
    if count and int(units.max()) > 0xFFFF:
        raise WireDecodeError(f"wstring code unit {int(units.max()):#x} is not UTF-16")
    text = units.astype("<u2").tobytes().decode("utf-16-le")
    if bound is not None and len(text) > bound:
        raise over_bound(len(text), bound)
    return text, pos + count * 4


def _read_string(
    mv: memoryview, pos: int, lim: int, u32: struct.Struct, bound: int | None
) -> tuple[str, int]:
    pos = (pos + 3) & -4
    (count,) = u32.unpack_from(mv, pos)
    pos += 4
    if count > lim - pos:
        raise too_long(count, 1, lim - pos)
    text = mv[pos : pos + count - 1].tobytes().decode()
    if bound is not None and len(text) > bound:
        raise over_bound(len(text), bound)
    return text, pos + count


def _read_count(  # noqa: PLR0917 (generated code calls it positionally)
    mv: memoryview, pos: int, lim: int, u32: struct.Struct, bound: int | None, least: int
) -> tuple[int, int]:
    pos = (pos + 3) & -4
    (count,) = u32.unpack_from(mv, pos)
    pos += 4
    if bound is not None and count > bound:
        raise over_bound(count, bound)
    if count * least > lim - pos:
        raise too_long(count, least, lim - pos)
    return count, pos


def read_strings(  # noqa: PLR0917 (generated code calls it positionally)
    mv: memoryview,
    pos: int,
    lim: int,
    u32: struct.Struct,
    count: int | None,
    bound: int | None,
    string_bound: int | None,
    wide: bool,
) -> tuple[list[str], int]:
    """A fixed array (``count`` given) or a sequence (count read first) of (w)strings."""
    if count is None:
        count, pos = _read_count(mv, pos, lim, u32, bound, 4)
    values: list[str] = []
    append = values.append
    unpack = u32.unpack_from
    index = 0
    try:
        if wide:
            for index in range(count):  # noqa: B007 (the handler names the index)
                text, pos = read_wstring(mv, pos, lim, u32, string_bound)
                append(text)
            return values, pos
        for index in range(count):  # noqa: B007
            pos = (pos + 3) & -4
            (size,) = unpack(mv, pos)
            pos += 4
            if size > lim - pos:
                raise too_long(size, 1, lim - pos)
            text = mv[pos : pos + size - 1].tobytes().decode()
            if string_bound is not None and len(text) > string_bound:
                raise over_bound(len(text), string_bound)
            append(text)
            pos += size
    except WireDecodeError as error:
        raise error.within(f"[{index}]") from None
    except Exception as error:
        raise decode_failure(error, f"[{index}]", pos, lim) from None
    return values, pos


def read_messages(  # noqa: PLR0917 (generated code calls it positionally)
    mv: memoryview,
    pos: int,
    lim: int,
    u32: struct.Struct,
    decode: DecodeFunction,
    count: int | None,
    bound: int | None,
    least: int,
) -> tuple[Sequence[Any], int]:
    """A fixed array (``count`` given) or a sequence (count read first) of messages."""
    if count is None:
        count, pos = _read_count(mv, pos, lim, u32, bound, least)
    values = []
    for index in range(count):
        try:
            value, pos = decode(mv, pos, lim)
        except WireDecodeError as error:
            raise error.within(f"[{index}]") from None
        values.append(value)
    return values, pos


def body_of(data: Any) -> tuple[memoryview, bool]:
    """The CDR body after the encapsulation header, and whether it is little-endian."""
    mv = data if data.__class__ is memoryview else memoryview(data)
    if mv.format != "B" or mv.ndim != 1:
        mv = mv.cast("B")
    if len(mv) < 4:
        raise DecodeError(f"{len(mv)} bytes is too short for a CDR encapsulation header")
    if mv[0] == 0:
        kind = mv[1]
        if kind == 1:
            return mv[4:], True
        if kind == 0:
            return mv[4:], False
    raise DecodeError(
        f"unsupported CDR encapsulation {bytes(mv[:2]).hex()} (expected 0001 little-endian or "
        "0000 big-endian XCDR1)"
    )


# -- encoding ----------------------------------------------------------------------------------
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
        raise FieldError(label[0][0], f"cannot encode ({error})") from None


def encode_failure(error: BaseException, label: str, data: Any) -> FieldError:
    """Turn whatever an encoder's fast path raised into a ``FieldError`` naming the field."""
    if not isinstance(data, Mapping):
        return FieldError("", f"expected dict, got {describe(data)}")
    return FieldError(label, f"cannot encode ({describe(error)}: {error})")


def utf8z(value: Any, bound: int | None) -> bytes:
    """A string's UTF-8 bytes and the NUL terminator CDR writes after them."""
    if value.__class__ is not str or (bound is not None and len(value) > bound):
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
        return value
    if isinstance(value, np.ndarray) and value.dtype == np.uint8 and value.flags.c_contiguous:
        return value.reshape(-1).data
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
        if fixed:
            converted: Any = uint8_array(value, size or 0, "")
        else:
            converted = uint8_sequence(value, size, "")
        return converted, len(converted)
    if value.__class__ is list or value.__class__ is tuple:
        # struct checks every element's type and range; anything it rejects is checked again
        # below, which names the bad element.
        count = len(value)
        if size is None or (count == size if fixed else count <= size):
            with contextlib.suppress(struct.error, OverflowError, TypeError):
                return struct.pack(
                    f"{_ORDER[dtype.byteorder]}{count}{STRUCT_CODES[kind]}", *value
                ), count
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


# -- views ---------------------------------------------------------------------------------------
def view_fields(value: Any) -> Any:
    """A decoded view's fields as a dict (so views encode like dicts); anything else as is."""
    cls = type(value)
    if isinstance(getattr(cls, "msg_type", None), str) and hasattr(cls, "__slots__"):
        return {name: getattr(value, name) for name in cls.__slots__}
    return value


def view_repr(view: Any) -> str:
    fields = ", ".join(f"{name}={getattr(view, name)!r}" for name in type(view).__slots__)
    return f"{view.msg_type}({fields})"


# -- Fast DDS's size estimate --------------------------------------------------------------------
Definitions = Mapping[str, tuple[str, tuple[Any, ...]]]


def fastdds_estimated_size(
    value: Any, full_name: str, definitions: Definitions, pos: int = 0
) -> int:
    """The body size Fast DDS's typesupport estimates for ``value`` (``rmw_serialize`` output).

    ``rclpy.serialization.serialize_message`` returns that many bytes, though the estimate
    aligns the elements of empty sequences of 8-byte values and serialising does not, so its
    output may end with a few unwritten bytes. The decoders accept them (and no more).
    """
    rows = definitions[full_name][1]
    if not rows:
        return pos + 1
    for name, kind, element, _bound, container, _size, _default in rows:
        field = value[name] if isinstance(value, Mapping) else getattr(value, name)
        if container == "single":
            pos = _estimate_one(field, kind, element, definitions, pos)
            continue
        if container != "array":
            pos = ((pos + 3) & -4) + 4
        if kind == "primitive":
            itemsize = PRIMITIVE_SIZES[element]
            pos = ((pos + itemsize - 1) & -itemsize) + itemsize * len(field)
        else:
            for item in field:
                pos = _estimate_one(item, kind, element, definitions, pos)
    return pos


def _estimate_one(value: Any, kind: str, element: str, definitions: Definitions, pos: int) -> int:
    if kind == "primitive":
        itemsize = PRIMITIVE_SIZES[element]
        return ((pos + itemsize - 1) & -itemsize) + itemsize
    if kind == "string":
        return ((pos + 3) & -4) + 4 + len(value.encode()) + 1
    if kind == "wstring":
        # The estimate counts a terminating wchar_t that is never written.
        return ((pos + 3) & -4) + 4 + 2 * len(value.encode("utf-16-le")) + 4
    return fastdds_estimated_size(value, element, definitions, pos)
