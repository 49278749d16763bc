"""Straight-line CDR for the commonest small std_msgs values, at an agent's call sites.

A ``std_msgs/String`` is 4 header bytes, a length, the UTF-8 bytes and a NUL; an ``Int32`` is 4
header bytes and 4 value bytes; a ``Float64MultiArray`` of a flat array is 7 words (one
dimension labelled ``''``, its size and stride, ``data_offset`` 0, the count) and the array's
bytes (rclpy writes no dimension: 3 words). The general path (codec ``to_fields`` -> generated
``from_dict`` -> join; ``body_of`` -> generated view -> codec ``decode``) spends 1-6 µs per
message on frames and checks such a message does not need, and a 100 Hz publisher runs it on a
cold cache, where it costs several times that (bench/transport.py, bench/agents.py). Peers
(``transport/``) and the ``pub``/``sub`` agents' raw CDR path (``ros/raw_path.py``) both take
these paths.

A fast path handles only what it can prove is well formed and gives exactly the general
path's result there (tests/transport/test_fast_paths.py and tests/codecs/test_fast_paths.py
compare both on arbitrary values and bytes); everything else — a wrong type, an out-of-range
int, a big-endian or malformed payload, a stray trailing byte — goes to the general path, which
raises its usual error. Fast paths apply only when the registry's codec of the type is the
stock one and the agent has no ``encode_func``/``decode_func``: a user codec is never bypassed.
"""

from __future__ import annotations

import math
import struct
import sys
from collections.abc import Callable
from typing import Any

import numpy as np

from pyconnect.codecs.multi_array import MultiArrayCodec
from pyconnect.codecs.std_scalars import FloatCodec, IntCodec, StringCodec
from pyconnect.typesys.primitives import FLOAT32_MAX, INTEGER_RANGES, STRUCT_CODES

Encode = Callable[[Any], bytes]
Decode = Callable[[bytes], Any]

_LITTLE = b"\x00\x01\x00\x00"  # the XCDR1 little-endian encapsulation header, no options
_U32 = struct.Struct("<I")
_STRING_HEAD = struct.Struct("<4sI")
# dim count 1, label length 1, the label's NUL and padding, size, stride, data_offset, count
_FLAT_LAYOUT = struct.Struct("<4s7I")


def fast_paths(
    value_codec: object,
    *,
    general_encode: Encode,
    general_decode: Decode,
    writable_arrays: bool = False,
) -> tuple[Encode, Decode] | None:
    """``(encode, decode)`` for ``value_codec``'s type, or None when it has no fast path.

    A flat ``*MultiArray`` decodes to a read-only view over the payload (a peer's general path
    gives one), or with ``writable_arrays`` to an array over a copy of it (an agent's raw path
    hands out writable arrays, as the class path does).
    """
    if type(value_codec) is MultiArrayCodec:
        if value_codec.name == "ByteMultiArray" or sys.byteorder != "little":
            return None  # ByteMultiArray's data are bytes; elsewhere CDR's order needs a swap
        return (
            _flat_multi_array(value_codec, general_encode),
            _flat_multi_array_decode(value_codec, general_decode, copy=writable_arrays),
        )
    codec_class = type(value_codec)
    if codec_class is StringCodec:
        return _string(general_encode, general_decode)
    if codec_class is IntCodec and value_codec.kind != "char":  # type: ignore[attr-defined]
        kind: str = value_codec.kind  # type: ignore[attr-defined]
        return _integer(kind, general_encode, general_decode)
    if codec_class is FloatCodec:
        name: str = value_codec.name  # type: ignore[attr-defined]
        return _float(name == "Float32", general_encode, general_decode)
    return None


def fast_encoder(value_codec: object, general_encode: Encode) -> Encode | None:
    """The encoding half of ``fast_paths`` (a publisher's), or None."""
    paths = fast_paths(value_codec, general_encode=general_encode, general_decode=_no_decode)
    return None if paths is None else paths[0]


def fast_decoder(value_codec: object, general_decode: Decode) -> Decode | None:
    """The decoding half of ``fast_paths`` for a ``sub`` agent's raw path (writable arrays), or
    None where it is the general."""
    paths = fast_paths(
        value_codec, general_encode=_no_encode, general_decode=general_decode, writable_arrays=True
    )
    return None if paths is None or paths[1] is general_decode else paths[1]


def _no_decode(payload: bytes) -> Any:
    raise AssertionError("fast_encoder's caller decodes nothing")  # pragma: no cover


def _no_encode(value: Any) -> bytes:
    raise AssertionError("fast_decoder's caller encodes nothing")  # pragma: no cover


def _string(general_encode: Encode, general_decode: Decode) -> tuple[Encode, Decode]:
    pack_head, unpack_u32 = _STRING_HEAD.pack, _U32.unpack_from
    # The NUL, then padding to a 4-byte boundary (the body is the length word and ``size`` bytes).
    tails = (b"\0", b"\0\0\0\0", b"\0\0\0", b"\0\0")

    def encode(value: Any) -> bytes:
        if value.__class__ is str and "\0" not in value:  # the general path refuses a NUL
            try:
                data = value.encode()
            except UnicodeEncodeError:
                return general_encode(value)  # the general path names the field and reason
            size = len(data) + 1
            return pack_head(_LITTLE, size) + data + tails[size & 3]
        return general_encode(value)

    def decode(payload: bytes) -> Any:
        if payload[:2] == b"\x00\x01" and len(payload) >= 9:
            (size,) = unpack_u32(payload, 4)
            end = 8 + size
            if size and end <= len(payload) <= end + 3 and payload[end - 1] == 0:
                text = payload[8 : end - 1]
                if 0 not in text:  # the general path ends the text at an inner NUL, as rclpy
                    return text.decode("utf-8", "replace")
        return general_decode(payload)

    return encode, decode


def _scalar_decode(fmt: str, general_decode: Decode) -> Decode:
    layout = struct.Struct("<" + fmt)
    unpack, size = layout.unpack_from, layout.size
    shortest = 4 + size
    longest = shortest + 3  # at most 3 bytes of padding may follow

    def decode(payload: bytes) -> Any:
        if shortest <= len(payload) <= longest and payload[:2] == b"\x00\x01":
            return unpack(payload, 4)[0]
        return general_decode(payload)

    return decode


def _scalar_encode(fmt: str, accept: Callable[[Any], bool], general_encode: Encode) -> Encode:
    layout = struct.Struct("<4s" + fmt)
    pack = layout.pack
    pad = b"\0" * (-layout.size & 3)

    def encode(value: Any) -> bytes:
        if accept(value):
            return pack(_LITTLE, value) + pad
        return general_encode(value)

    return encode


def _integer(kind: str, general_encode: Encode, general_decode: Decode) -> tuple[Encode, Decode]:
    fmt = STRUCT_CODES[kind]
    low, high = INTEGER_RANGES[kind]

    def accept(value: Any) -> bool:
        return value.__class__ is int and low <= value <= high

    return _scalar_encode(fmt, accept, general_encode), _scalar_decode(fmt, general_decode)


def _float(single: bool, general_encode: Encode, general_decode: Decode) -> tuple[Encode, Decode]:
    fmt = "f" if single else "d"
    isfinite = math.isfinite

    def accept(value: Any) -> bool:
        if value.__class__ is not float:
            return False
        return not single or not isfinite(value) or abs(value) <= FLOAT32_MAX

    return _scalar_encode(fmt, accept, general_encode), _scalar_decode(fmt, general_decode)


def _flat_multi_array(codec: MultiArrayCodec, general_encode: Encode) -> Encode:
    """A C-contiguous 1-D ndarray of the message's own dtype."""
    dtype = codec.dtype
    itemsize = dtype.itemsize
    pack_layout = _FLAT_LAYOUT.pack
    # The body's 28 bytes, then the elements aligned to their size (CDR counts from the body).
    align = b"\0" * (-28 % itemsize)
    ndarray = np.ndarray

    def encode(value: Any) -> bytes:
        if (
            value.__class__ is ndarray
            and value.dtype is dtype
            and value.ndim == 1
            and value.flags.c_contiguous
        ):
            size = value.shape[0]
            if size and size <= 0xFFFFFFFF:
                end = 28 + len(align) + size * itemsize
                return b"".join(
                    (pack_layout(_LITTLE, 1, 1, 0, size, size, 0, size), align, value.data,
                     _TAILS[end & 3])
                )  # fmt: skip
        return general_encode(value)

    return encode


def _flat_multi_array_decode(
    codec: MultiArrayCodec, general_decode: Decode, *, copy: bool
) -> Decode:
    """A layout without dimensions (rclpy's default) or with one unlabelled dimension spanning
    all the data (what encode writes), ``data_offset`` 0, at least one element: the 1-D array
    the general path gives, over a copy of the payload (writable, under ``FAST_DECODE_BYTES``)
    or over the payload itself."""
    dtype = codec.dtype
    itemsize = dtype.itemsize
    # Payload offsets of the data: 4 header bytes, then the body's 12 or 28 bytes aligned.
    bare_start = 4 + 12 + (-12 % itemsize)
    flat_start = 4 + 28 + (-28 % itemsize)
    unpack_u32, unpack_bare, unpack_flat = (
        _U32.unpack_from,
        _BARE_TAIL.unpack_from,
        _FLAT_TAIL.unpack_from,
    )
    frombuffer = np.frombuffer
    longest = FAST_DECODE_BYTES if copy else sys.maxsize

    def decode(payload: bytes) -> Any:
        length = len(payload)
        if 16 <= length < longest and payload[:2] == b"\x00\x01":
            (dims,) = unpack_u32(payload, 4)
            if dims == 0:
                offset, count = unpack_bare(payload, 8)
                start = bare_start
            elif dims == 1 and length >= 32:
                label, size, _stride, offset, count = unpack_flat(payload, 8)
                start = flat_start if label == _EMPTY_LABEL and size == count else 0
            else:
                start = 0
            if start and offset == 0 and count:
                end = start + count * itemsize
                if end <= length <= end + 3:
                    return frombuffer(bytearray(payload) if copy else payload, dtype, count, start)
        return general_decode(payload)

    return decode


FAST_DECODE_BYTES = 64 * 1024
"""Larger payloads take the general path, which makes the taken bytes writable without a copy."""
_BARE_TAIL = struct.Struct("<2I")  # data_offset, count
# The one dimension's label (length 1, its NUL, padding), size and stride; data_offset, count.
_FLAT_TAIL = struct.Struct("<8s4I")
_EMPTY_LABEL = b"\x01\x00\x00\x00\x00\x00\x00\x00"
_TAILS = (b"", b"\0\0\0", b"\0\0", b"\0")
"""Zero bytes that bring a body of ``end`` bytes (``end & 3``) to a 4-byte boundary."""
