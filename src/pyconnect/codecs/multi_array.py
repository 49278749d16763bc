"""std_msgs/*MultiArray ↔ ``numpy.ndarray`` shaped by the message's layout.

Decode reads ``layout.dim`` (sizes and strides, outermost first) and ``data_offset`` and returns
a zero-copy strided view; with no dimensions the data is 1-D. Encode writes a C-ordered layout
with one dimension per axis. Dimension labels and any padding between rows are dropped, so
``lossless`` is False. ByteMultiArray's elements are uint8.
"""

from __future__ import annotations

import math
from functools import partial
from typing import Any

import numpy as np
import numpy.typing as npt

from pyconnect.codecs.base import FieldsCodec, check_message_type, decode_failure
from pyconnect.codecs.buffers import ARRAY_TYPECODES, numeric_view
from pyconnect.errors import DecodeError, EncodeError, type_name_of
from pyconnect.typesys.primitives import FLOAT32_OVERFLOW

DTYPES: dict[str, str] = {
    "ByteMultiArray": "uint8",
    "Int8MultiArray": "int8",
    "UInt8MultiArray": "uint8",
    "Int16MultiArray": "int16",
    "UInt16MultiArray": "uint16",
    "Int32MultiArray": "int32",
    "UInt32MultiArray": "uint32",
    "Int64MultiArray": "int64",
    "UInt64MultiArray": "uint64",
    "Float32MultiArray": "float32",
    "Float64MultiArray": "float64",
}


_MAX_DIMS = 32  # numpy's limit before version 2; plenty for a tensor in a message


class MultiArrayCodec(FieldsCodec):
    """One std_msgs ``*MultiArray`` type ↔ ndarray."""

    lossless = False

    def __init__(self, name: str) -> None:
        self.name = name
        self.msg_type = f"std_msgs/msg/{name}"
        self.dtype = np.dtype(DTYPES[name])
        # Looked up once: dtype.name costs microseconds per call (the encode hot path).
        self._typecode = ARRAY_TYPECODES.get(self.dtype.name, "")
        # Classes checked to be this type (or to name none): numeric_view would cast a
        # Float64MultiArray's data for an Int8MultiArray codec rather than fail.
        self._classes: set[type] = set()

    def decode(self, msg: Any) -> npt.NDArray[Any]:
        if type(msg) not in self._classes:  # once per class; noise next to the view's cost
            check_message_type(msg, self.msg_type)
            self._classes.add(type(msg))
        try:
            data = numeric_view(msg.data, self.dtype)
            layout = msg.layout
            dims = list(layout.dim)
            offset = layout.data_offset
            if offset > len(data):  # a slice would quietly give no elements
                raise DecodeError(
                    f"{self.name}.layout.data_offset: {offset} is past the {len(data)} "
                    "elements of data"
                )
            if not dims:
                return data[offset:]
            shape = tuple(int(d.size) for d in dims)
            element_strides = [int(d.stride) for d in dims[1:]] + [1]
        except (AttributeError, TypeError) as error:  # free until raised: a class, a Point()
            raise decode_failure(error, msg, self.msg_type) from None
        if len(shape) > _MAX_DIMS:
            raise DecodeError(
                f"{self.name}.layout.dim: expected at most {_MAX_DIMS} dimensions, got {len(shape)}"
            )
        # A layout comes off the wire: it must not describe more elements than the data holds,
        # or a zero stride would make a view that claims (and, once copied, allocates) far more.
        count = math.prod(shape)
        if count > len(data) - offset:
            raise DecodeError(
                f"{self.name}.data: layout {shape} needs {count} elements after offset "
                f"{offset}, got {max(len(data) - offset, 0)}"
            )
        if count == 0:
            try:
                return np.empty(shape, self.dtype)
            except ValueError:  # the other dimensions multiply past what numpy can index
                raise DecodeError(
                    f"{self.name}.layout.dim: sizes {shape} are too large for an array"
                ) from None
        if len(shape) == 1:
            # One dimension (what encode writes for a flat array): its stride never matters,
            # and the slice is the view as_strided would make, without its ~7 µs.
            return data[offset : offset + count]
        last = offset + sum((n - 1) * s for n, s in zip(shape, element_strides, strict=True))
        if last >= len(data):
            raise DecodeError(
                f"{self.name}.data: layout {shape} with strides "
                f"{tuple(element_strides)} and offset {offset} reads element {last}, "
                f"got {len(data)} elements"
            )
        itemsize = self.dtype.itemsize
        view: npt.NDArray[Any] = np.lib.stride_tricks.as_strided(
            data[offset:],
            shape=shape,
            strides=tuple(s * itemsize for s in element_strides),
            writeable=data.flags.writeable,
        )
        return view

    def _checked(self, value: Any) -> npt.NDArray[Any]:
        if not isinstance(value, np.ndarray):
            raise EncodeError(f"{self.name}: expected numpy.ndarray, got {type_name_of(value)}")
        if value.ndim == 0:
            # No dimension to write: it would come back as shape (1,).
            raise EncodeError(
                f"{self.name}: expected an array of at least one dimension, got a 0-d array "
                "(value.reshape(1) sends one element)"
            )
        if value.ndim > _MAX_DIMS:
            # Decode refuses more (numpy 2 makes up to 64): every value sent must come back.
            raise EncodeError(
                f"{self.name}: expected an array of at most {_MAX_DIMS} dimensions, got "
                f"{value.ndim}"
            )
        if value.dtype == self.dtype:
            return value
        if (
            value.dtype.kind == "b"  # bools are refused where numbers go, as everywhere
            or not np.can_cast(value.dtype, self.dtype, casting="same_kind")
            or (
                value.dtype.kind in "iu"
                and self.dtype.kind in "iu"
                and not np.can_cast(value.dtype, self.dtype, casting="safe")
            )
        ):
            raise EncodeError(
                f"{self.name}.data: expected {self.dtype.name} values, got {value.dtype.name}"
            )
        with np.errstate(over="ignore"):
            cast = value.astype(self.dtype, copy=False)
        if value.dtype.kind == "f" and self.dtype.itemsize < value.dtype.itemsize:
            # float64 -> float32: a finite value past float32's range would become inf.
            overflow = np.isinf(cast) & np.isfinite(value)
            if overflow.any():
                index = np.unravel_index(int(np.flatnonzero(overflow)[0]), value.shape)
                where = "".join(f"[{int(i)}]" for i in index)
                # float32, the only narrower float of ROS arrays: check_float32's words
                raise EncodeError(
                    f"{self.name}.data{where}: expected {self.dtype.name} "
                    f"(|x| < {FLOAT32_OVERFLOW!r}), got {float(value[index])!r}"
                )
        return cast

    def _layout(self, array: npt.NDArray[Any]) -> dict[str, Any]:
        # ROS strides count elements of this and all inner dimensions: C order, no padding.
        dims: list[dict[str, Any]] = []
        stride = 1
        for size in reversed(array.shape):
            stride *= size
            dims.insert(0, {"label": "", "size": int(size), "stride": int(stride)})
        return {"dim": dims, "data_offset": 0}

    def to_fields(self, value: Any) -> dict[str, Any]:
        if (
            value.__class__ is np.ndarray
            and value.dtype is self.dtype
            and value.ndim == 1
            and self.name != "ByteMultiArray"
            and value.flags.c_contiguous
        ):
            # The common case (a flat array of the message's own dtype) in a few steps: a
            # publisher at 100 Hz runs this on a cold cache, where each call costs microseconds.
            size = value.shape[0]
            dim = {"label": "", "size": size, "stride": size}
            return {"layout": {"dim": [dim], "data_offset": 0}, "data": value}
        array = self._checked(value)
        data: Any = np.ascontiguousarray(array).reshape(-1)
        if self.name == "ByteMultiArray":
            data = data.tobytes()
        return {"layout": self._layout(array), "data": data}


byte_multi_array_codec = partial(MultiArrayCodec, "ByteMultiArray")
int8_multi_array_codec = partial(MultiArrayCodec, "Int8MultiArray")
uint8_multi_array_codec = partial(MultiArrayCodec, "UInt8MultiArray")
int16_multi_array_codec = partial(MultiArrayCodec, "Int16MultiArray")
uint16_multi_array_codec = partial(MultiArrayCodec, "UInt16MultiArray")
int32_multi_array_codec = partial(MultiArrayCodec, "Int32MultiArray")
uint32_multi_array_codec = partial(MultiArrayCodec, "UInt32MultiArray")
int64_multi_array_codec = partial(MultiArrayCodec, "Int64MultiArray")
uint64_multi_array_codec = partial(MultiArrayCodec, "UInt64MultiArray")
float32_multi_array_codec = partial(MultiArrayCodec, "Float32MultiArray")
float64_multi_array_codec = partial(MultiArrayCodec, "Float64MultiArray")
