"""``sensor_msgs/Image`` ↔ ``numpy.ndarray``: a zero-copy view on decode, one copy on encode.

Decode returns a view on the message buffer, shape (H, W) for one channel and (H, W, C)
otherwise, with row stride ``step`` (padded rows are skipped, not copied) and a big-endian
dtype (``>u2``) when ``is_bigendian`` is set, so values are right without a byte swap.
Encode writes packed rows (``step = width * pixel bytes``) with one copy of the pixels; a
big-endian array is written as is with ``is_bigendian = 1``.

Dropped (so ``lossless`` is False): the header (use ``stamped=True``), row padding, and for a
native-order array the original byte order. The semi-planar ``nv21``/``nv12``/``nv24``
encodings decode to all their buffer rows (see ``image_encodings``); a padded ``nv24`` is the
one copy on decode, as its chroma rows have twice the luma rows' padding.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

from pyconnect.codecs.base import FieldsCodec, check_message_type, wrong_message
from pyconnect.codecs.buffers import byte_array, contiguous_bytes
from pyconnect.codecs.image_encodings import (
    UnknownEncodingError,
    infer_encoding,
    pixel_format,
)
from pyconnect.codecs.message_slots import blank, field_reader, has_slot_layout, zero_header
from pyconnect.errors import DecodeError, EncodeError, type_name_of

__all__ = ["ImageCodec", "decode_image", "encode_image", "image_fields"]

_NATIVE_BIG = sys.byteorder == "big"

# (encoding, is_bigendian) -> (dtype in that byte order, channels, pixel bytes, rows factor)
_Layout = tuple[np.dtype[Any], int, int, Any, int]
_LAYOUTS: dict[tuple[str, int], _Layout] = {}
# Encodings come from the data: past this many, layouts are computed each time rather than
# kept, so a stream of distinct encodings cannot grow the cache.
_MAX_LAYOUTS = 256


def _layout(encoding: str, big_endian: bool) -> _Layout:
    try:
        fmt = pixel_format(encoding)
    except UnknownEncodingError as error:
        raise DecodeError(f"Image.encoding: {error}") from None
    dtype = fmt.dtype
    if dtype.itemsize > 1:
        dtype = dtype.newbyteorder(">" if big_endian else "<")
    rows_per_row = None if fmt.rows_per_row == 1 else fmt.rows_per_row
    layout = (dtype, fmt.channels, fmt.pixel_bytes, rows_per_row, dtype.itemsize)
    if len(_LAYOUTS) < _MAX_LAYOUTS:
        _LAYOUTS[(encoding, big_endian)] = layout
        _LAYOUTS[(encoding, int(big_endian))] = layout
    return layout


_FIELDS = ("encoding", "is_bigendian", "height", "width", "step", "data")
# Keyed by class alone: the lookup is on the decode hot path.
_READERS: dict[type, Callable[[Any], Any]] = {}


def decode_image(msg: Any) -> npt.NDArray[Any]:
    """A zero-copy ndarray view of an Image message's pixels (reads attributes only)."""
    cls = type(msg)
    reader = _READERS.get(cls)
    if reader is None:
        check_message_type(msg, "sensor_msgs/msg/Image")  # once per class: a class, a Point()
        reader = _READERS[cls] = field_reader(cls, _FIELDS)
    try:
        encoding, big_endian, height, width, step, data = reader(msg)
    except AttributeError:  # free until raised: lookup(Image).decode(y) with y of another type
        raise wrong_message(msg, "sensor_msgs/msg/Image") from None
    # 0/1 and False/True hash alike, so the raw flag is the key.
    layout = _LAYOUTS.get((encoding, big_endian)) or _layout(encoding, bool(big_endian))
    dtype, channels, pixel_bytes, rows_per_row, itemsize = layout
    rows = height if rows_per_row is None else int(height * rows_per_row)
    row_bytes = width * pixel_bytes
    if step < row_bytes:
        raise DecodeError(
            f"Image.step: expected at least {row_bytes} (width {width} × "  # noqa: RUF001
            f"{pixel_bytes} bytes per pixel of {encoding}), got {step}"
        )
    size = step * rows
    if len(data) < size:
        what = f"height {height}" if rows == height else f"{rows} rows for height {height}"
        raise DecodeError(
            f"Image.data: expected at least {size} bytes (step {step} × {what}), got {len(data)}"  # noqa: RUF001
        )
    shape = (rows, width, channels) if channels > 1 else (rows, width)
    try:
        if step == row_bytes:
            # Without explicit strides numpy builds the view about 2.5* faster.
            view: npt.NDArray[Any] = np.ndarray(shape, dtype, buffer=data)
            return view
        if encoding == "nv24":
            return nv24_rows(data, height, width, step)
        strides = (step, itemsize) if channels == 1 else (step, pixel_bytes, itemsize)
        view = np.ndarray(shape, dtype, buffer=data, strides=strides)
        return view
    except TypeError:
        # Not a buffer (a list of ints built by hand): one copy is the best there is.
        if encoding == "nv24":
            return nv24_rows(np.asarray(data, np.uint8), height, width, step)
        return decode_image_from_bytes(np.asarray(data, np.uint8), layout, shape, step)


def nv24_rows(data: Any, height: int, width: int, step: int) -> npt.NDArray[np.uint8]:
    """The natural value of a padded ``nv24`` buffer: (3 * height, width), one copy.

    V4L2 pads each chroma row (``2 * width`` bytes) to ``2 * step``, twice a luma row's
    padding, so no single row stride fits both planes.
    """
    luma = np.ndarray((height, width), np.uint8, buffer=data, strides=(step, 1))
    chroma = np.ndarray(
        (height, 2 * width), np.uint8, buffer=data, offset=height * step, strides=(2 * step, 1)
    )
    return np.concatenate((luma, chroma.reshape(2 * height, width)))


def decode_image_from_bytes(
    data: npt.NDArray[np.uint8], layout: _Layout, shape: tuple[int, ...], step: int
) -> npt.NDArray[Any]:
    """The view for a buffer already converted to a uint8 array."""
    dtype, channels, pixel_bytes, _, itemsize = layout
    strides = (step, itemsize) if channels == 1 else (step, pixel_bytes, itemsize)
    view: npt.NDArray[Any] = np.ndarray(shape, dtype, buffer=data, strides=strides)
    return view


# (dtype, channels or -ndim, explicit encoding) -> (encoding, pixel bytes, rows num, rows den,
# is_bigendian): what encode needs, worked out once per kind of array.
_Plan = tuple[str, int, int, int, int]
_PLANS: dict[tuple[Any, int, str | None], _Plan] = {}


def _plan(value: Any, encoding: str | None) -> _Plan:
    if not isinstance(value, np.ndarray):
        raise EncodeError(f"Image: expected numpy.ndarray, got {type_name_of(value)}")
    shape = value.shape
    key = (value.dtype, shape[2] if len(shape) == 3 else -len(shape), encoding)
    plan = _PLANS.get(key) or _make_plan(value, encoding, key)
    if plan[2] != 1 and shape[0] % plan[2]:
        raise EncodeError(
            f"Image.data: encoding {plan[0]!r} expects a row count that is a multiple of "
            f"{plan[2]} (image height × {plan[2]}/{plan[3]}), got {shape[0]}"  # noqa: RUF001
        )
    return plan


def _make_plan(value: npt.NDArray[Any], encoding: str | None, key: Any) -> _Plan:
    if value.ndim not in (2, 3):
        raise EncodeError(
            f"Image: expected an ndarray of shape (H, W) or (H, W, C), got shape {value.shape}"
        )
    channels = 1 if value.ndim == 2 else value.shape[2]
    if encoding is None:
        inferred = infer_encoding(value.dtype, channels)
        if inferred is None:
            raise EncodeError(
                f"Image: cannot infer an encoding for {value.dtype.name} with {channels} "
                "channels (dtypes: uint8, int8, uint16, int16, int32, float32, float64; 1-512 "
                "channels); pass ImageCodec(encoding=...)"
            )
        encoding = inferred
    try:
        fmt = pixel_format(encoding)
    except UnknownEncodingError as error:
        raise EncodeError(f"Image.encoding: {error}") from None
    if value.dtype.str[1:] != fmt.dtype.str[1:]:
        raise EncodeError(
            f"Image.data: encoding {encoding!r} expects {fmt.dtype.name}, got {value.dtype.name}"
        )
    if channels != fmt.channels or (fmt.channels > 1 and value.ndim != 3):
        wanted = "(H, W)" if fmt.channels == 1 else f"(H, W, {fmt.channels})"
        raise EncodeError(
            f"Image.data: encoding {encoding!r} expects shape {wanted}, got {value.shape}"
        )
    byteorder = value.dtype.byteorder
    big_endian = value.dtype.itemsize > 1 and (
        byteorder == ">" or (byteorder == "=" and _NATIVE_BIG)
    )
    plan = (
        encoding,
        fmt.pixel_bytes,
        fmt.rows_per_row.numerator,
        fmt.rows_per_row.denominator,
        int(big_endian),
    )
    _PLANS[key] = plan
    return plan


def image_fields(value: Any, *, encoding: str | None = None) -> dict[str, Any]:
    """The Image message fields of an ndarray as a plain dict (``data`` is a byte memoryview)."""
    name, pixel_bytes, rows_num, rows_den, big_endian = _plan(value, encoding)
    width = value.shape[1]
    return {
        "height": value.shape[0] * rows_den // rows_num,
        "width": width,
        "encoding": name,
        "is_bigendian": big_endian,
        "step": width * pixel_bytes,
        "data": contiguous_bytes(value),
    }


_CLASSES: list[Any] = []


def _image_classes() -> tuple[Any, Any, Any, bool]:
    if not _CLASSES:
        from builtin_interfaces.msg import Time
        from sensor_msgs.msg import Image
        from std_msgs.msg import Header

        _CLASSES.extend((Image, Header, Time, has_slot_layout(Image, Header, Time)))
    image_class, header_class, time_class, slotted = _CLASSES
    return image_class, header_class, time_class, slotted


def encode_image(value: Any, *, encoding: str | None = None) -> Any:
    """A new ``sensor_msgs/msg/Image`` holding one copy of ``value``'s pixels."""
    name, pixel_bytes, rows_num, rows_den, big_endian = _plan(value, encoding)
    height, width = value.shape[:2]
    image_class, header_class, time_class, slotted = _image_classes()
    # One copy into a fresh array('B'), which the message takes as is; assigning an ndarray
    # to msg.data would check every element (about 2,500x a memcpy).
    data = byte_array(value)
    if not slotted:
        msg = image_class(
            height=height * rows_den // rows_num,
            width=width,
            encoding=name,
            is_bigendian=big_endian,
            step=width * pixel_bytes,
        )
        msg.data = data
        return msg
    # Everything is validated: write the slots, skipping ~3 us of constructor and setters.
    msg = blank(image_class)
    msg._header = zero_header(header_class, time_class)
    msg._height = height * rows_den // rows_num
    msg._width = width
    msg._encoding = name
    msg._is_bigendian = big_endian
    msg._step = width * pixel_bytes
    msg._data = data
    return msg


class ImageCodec(FieldsCodec):
    """Image ↔ ndarray.

    ``encoding`` fixes the encoding on encode (default: inferred from the array) and converts
    to it on decode, as cv_bridge's ``desired_encoding`` does. ``copy=True`` makes decode
    return a writable array of its own (one copy) instead of a view of the message buffer,
    which is read-only for values read from bags or CDR bytes.
    """

    msg_type = "sensor_msgs/msg/Image"
    lossless = False

    def __init__(self, *, encoding: str | None = None, copy: bool = False) -> None:
        if encoding is not None:
            try:
                pixel_format(encoding)
            except UnknownEncodingError as error:
                raise EncodeError(f"ImageCodec: {error}") from None
        self.encoding = encoding
        self.copy = copy
        if encoding is not None or copy:
            # An instance attribute shadows the plain decode below only when it has work to do.
            self.__dict__["decode"] = self._decode_converted

    # The function itself, so a plain decode costs no extra Python frame.
    decode = staticmethod(decode_image)

    def _decode_converted(self, msg: Any) -> npt.NDArray[Any]:
        image = decode_image(msg)
        if self.encoding is not None and self.encoding != msg.encoding:
            from pyconnect.codecs.image_convert import ConversionError, convert

            try:
                image = convert(image, self.encoding, source_encoding=msg.encoding)
            except ConversionError as error:
                raise DecodeError(f"Image.encoding: {error}") from None
        # A conversion may hand back a view (a dtype-only change between generic encodings).
        return np.array(image) if self.copy and not image.flags.owndata else image

    def encode(self, value: Any) -> Any:
        # A hot codec keeps a direct path: the generated from_dict on to_fields costs ~1.5x
        # for small images (the header and checks); encode_image writes the slots directly.
        return encode_image(value, encoding=self.encoding)

    def to_fields(self, value: Any) -> dict[str, Any]:
        return image_fields(value, encoding=self.encoding)

    def __repr__(self) -> str:
        return f"ImageCodec(encoding={self.encoding!r}, copy={self.copy!r})"
