"""What generated CDR decoders call at run time: the path-carrying error and variable-length parts.

The generated code decodes runs of fixed-size values and numeric arrays inline; strings,
wstrings, sequences of strings or messages come here. Positions (``pos``) count from the end of
the 4-byte encapsulation header, where CDR alignment starts; ``lim`` is the length of that body.
"""

from __future__ import annotations

import struct
import sys
from array import array
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from pyconnect.codecs.field_checks import describe
from pyconnect.codecs.field_path import WireDecodeError
from pyconnect.errors import DecodeError
from pyconnect.typesys.primitives import PRIMITIVE_SIZES

# (segment, primitive kind, end offset in the run) for each value of a run of fixed-size values.
RunLabel = tuple[tuple[str, str, int], ...]
DecodeFunction = Callable[[memoryview, int, int], tuple[Any, int]]
# The byte order (struct's "<" or ">") whose numbers a memoryview cast reads as they are.
NATIVE_ORDER = "<" if sys.byteorder == "little" else ">"


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
        if not label:  # an empty message's one placeholder byte
            return WireDecodeError(f"truncated at offset {pos + 4} ({max(left, 0)} bytes left)")
        return WireDecodeError(f"malformed ({describe(error)}: {error})").within(label[0][0])
    if isinstance(error, UnicodeDecodeError):
        detail = f"invalid {error.encoding.upper()} ({error.reason} at byte {error.start})"
    elif isinstance(error, struct.error):
        detail = f"truncated at offset {pos + 4} ({max(left, 0)} bytes left)"
    else:
        detail = f"malformed ({describe(error)}: {error})"
    return WireDecodeError(detail).within(label)


def swapped_list(mv: memoryview, pos: int, count: int, code: str) -> list[Any]:
    """``count`` numbers of struct code ``code`` at ``pos``, stored in the other byte order."""
    values = array(code)
    values.frombytes(mv[pos : pos + count * values.itemsize])
    values.byteswap()
    return values.tolist()


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
            pos += size
            # rclpy's value (as the generated decoders read a string field): up to the first NUL,
            # a last byte that is not NUL kept (Fast CDR's reading), bad UTF-8 as U+FFFD.
            raw = mv[pos - size : pos - (mv[pos - 1] == 0 < size)].tobytes()
            text = (raw[: raw.index(0)] if 0 in raw else raw).decode("utf-8", "replace")
            if string_bound is not None and len(text) > string_bound:
                raise over_bound(len(text), string_bound)
            append(text)
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


# -- views ---------------------------------------------------------------------------------------
def _view_type(cls: type) -> str | None:
    # Views name their type in ``__msgtype__``, which no field can be called; those of modules
    # generated before used ``msg_type`` (a slot when a field has that name, then no str).
    for attribute in ("__msgtype__", "msg_type"):
        name = getattr(cls, attribute, None)
        if isinstance(name, str):
            return name
    return None


def view_fields(value: Any) -> Any:
    """A decoded view's fields as a dict (so views encode like dicts); anything else as is."""
    cls = type(value)
    if hasattr(cls, "__slots__") and _view_type(cls) is not None:
        return {name: getattr(value, name) for name in cls.__slots__}
    return value


def view_repr(view: Any) -> str:
    fields = ", ".join(f"{name}={getattr(view, name)!r}" for name in type(view).__slots__)
    return f"{_view_type(type(view))}({fields})"
