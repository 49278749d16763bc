"""Zero-copy numpy views of message arrays, and one-copy filling of rclpy's ``array.array`` fields.

rclpy gives numeric sequences as ``array.array`` and ``uint8[]`` as ``array('B')``; the CDR wire
codecs give numpy arrays (often read-only views); ``byte[]`` comes as a list of 1-byte ``bytes``.
Every reader here accepts all of them and copies nothing when the buffer protocol allows it.
``new_bytes`` and ``writable_bytes`` let numpy fill a ``bytes`` object nothing else holds yet.
"""

from __future__ import annotations

import array
import ctypes
from typing import Any

import numpy as np
import numpy.typing as npt

from pyconnect.codecs.field_checks import numeric_sequence
from pyconnect.errors import EncodeError

# numpy dtype -> array.array typecode of the same size, for rclpy's sequence fields.
ARRAY_TYPECODES: dict[str, str] = {
    "int8": "b",
    "uint8": "B",
    "int16": "h",
    "uint16": "H",
    "int32": "i",
    "uint32": "I",
    "int64": "q",
    "uint64": "Q",
    "float32": "f",
    "float64": "d",
}


def numeric_view(values: Any, dtype: npt.DTypeLike) -> npt.NDArray[Any]:
    """A 1-D array of ``dtype`` over ``values``, without a copy when it is a matching buffer."""
    wanted = np.dtype(dtype)
    if isinstance(values, np.ndarray):
        if values.dtype == wanted:
            return values.reshape(-1) if values.ndim != 1 else values
        return np.asarray(values, dtype=wanted).reshape(-1)
    if isinstance(values, array.array) and values.itemsize == wanted.itemsize:
        return np.frombuffer(values, dtype=wanted)
    if isinstance(values, bytes | bytearray | memoryview) and wanted.itemsize == 1:
        return np.frombuffer(values, dtype=wanted)
    if isinstance(values, list) and values and isinstance(values[0], bytes):
        return np.frombuffer(b"".join(values), dtype=wanted)
    return np.asarray(values, dtype=wanted).reshape(-1)


def byte_view(data: Any) -> npt.NDArray[np.uint8]:
    """The bytes of a ``uint8[]``/``byte[]`` field as a 1-D uint8 array (zero-copy if possible)."""
    if isinstance(data, np.ndarray) and data.dtype == np.uint8 and data.ndim == 1:
        return data
    return numeric_view(data, np.uint8)


def contiguous_bytes(values: npt.NDArray[Any]) -> memoryview:
    """A flat byte memoryview of ``values``; copies only when it is not C-contiguous.

    A structured dtype with gaps (a point cloud's padding) is copied byte for byte:
    ``ascontiguousarray`` would copy its fields only and leave the gaps uninitialised.
    """
    if values.__class__ is not np.ndarray:
        # A subclass keeps its own rules: np.matrix stays 2-D through reshape(-1), and a
        # masked array's .data is an ndarray. Its plain array has the same bytes.
        values = np.asarray(values)
    if not values.flags.c_contiguous:
        if values.dtype.names is not None:
            # A trailing axis of length 1 may take any stride, so its items view as bytes.
            values = values[..., np.newaxis].view(np.uint8)
        values = np.ascontiguousarray(values)
    if not values.size:
        return memoryview(b"")
    return values.reshape(-1).view(np.uint8).data


def byte_array(values: npt.NDArray[Any]) -> array.array[int]:
    """A new ``array('B')`` holding the bytes of ``values`` in C order: one copy of the data.

    Contiguous input is one ``memcpy`` (``frombytes``); a strided view (a slice, a transpose)
    is copied once, straight into the new buffer, instead of through a contiguous temporary.
    """
    result = array.array("B")
    if values.flags.c_contiguous or not values.size:
        result.frombytes(contiguous_bytes(values))
        return result
    result = array.array("B", b"\0") * values.nbytes
    target = np.frombuffer(result, values.dtype).reshape(values.shape)
    np.copyto(target, values)
    return result


def filled_array(values: Any, dtype: npt.DTypeLike, path: str) -> array.array[Any]:
    """A new ``array.array`` for an rclpy sequence field holding ``values`` (one copy).

    Assigning an ndarray to an rclpy sequence field checks it element by element; assigning an
    ``array.array`` of the right typecode is O(1), so building one with ``frombytes`` is the
    fast path.
    """
    wanted = np.dtype(dtype)
    typecode = ARRAY_TYPECODES[wanted.name]
    if not (isinstance(values, np.ndarray) and values.dtype == wanted):
        # Anything else element by element, as the generated codecs check a sequence field:
        # bools, strings and out-of-range numbers are refused, naming the element.
        return numeric_sequence(values, typecode, wanted.name, None, path)
    if values.ndim != 1:
        raise EncodeError(f"{path}: expected a 1-D sequence, got shape {values.shape}")
    result = array.array(typecode)
    result.frombytes(contiguous_bytes(values))
    return result


_new_bytes = ctypes.pythonapi.PyBytes_FromStringAndSize
_new_bytes.argtypes = (ctypes.c_void_p, ctypes.c_ssize_t)
_new_bytes.restype = ctypes.py_object


def new_bytes(size: int) -> bytes:
    """A ``bytes`` of ``size`` bytes, not yet filled: fill it (``writable_bytes``) before
    anything else sees it, as C code does with ``PyBytes_FromStringAndSize(NULL, n)``."""
    made: bytes = _new_bytes(None, size)
    return made


class _BytesHolder:
    """Exposes a ``bytes`` object's buffer to numpy as writable, and keeps the object alive."""

    __slots__ = ("__array_interface__", "data")

    def __init__(self, data: bytes) -> None:
        address = ctypes.cast(ctypes.c_char_p(data), ctypes.c_void_p).value
        self.__array_interface__ = {
            "data": (address, False),
            "shape": (len(data),),
            "typestr": "|u1",
            "version": 3,
        }
        self.data = data


def writable_bytes(data: bytes) -> npt.NDArray[np.uint8]:
    """A writable uint8 view of ``data``, which keeps it alive: only for a ``bytes`` made for
    this one use (``new_bytes``, or one rclpy just took) that nothing else holds or hashes,
    and longer than 1 byte (CPython shares those)."""
    return np.asarray(_BytesHolder(data))
