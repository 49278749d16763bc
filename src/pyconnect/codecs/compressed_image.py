"""sensor_msgs/CompressedImage ↔ ``numpy.ndarray`` decoded with OpenCV (BGR channel order).

Decode reads jpeg, png (16-bit png stays uint16, alpha is kept) and image_transport's
``compressedDepth`` (a 12-byte header, then a 16-bit 1-channel png; ``32FC1`` depth is
de-quantised to float32 metres, 0 → NaN). A corrupt or empty payload, or a compressedDepth png
of another type, gets a ``DecodeError``, never a crash.
Encode: ``CompressedImageCodec(format="jpeg", quality=95)`` or ``format="png"`` (lossless pixels,
``png_level`` 0-9), writing image_transport's format string (``"bgr8; jpeg compressed bgr8"``),
or ``format="compressedDepth"`` for uint16/float32 depth (pyconnect.codecs.compressed_depth).

``lossless`` is False: jpeg loses pixels, and the header and format string are dropped.
"""

from __future__ import annotations

import struct
from typing import Any

import numpy as np
import numpy.typing as npt

from pyconnect.codecs.base import FieldsCodec, check_message_type, decode_failure
from pyconnect.codecs.buffers import byte_view
from pyconnect.codecs.compressed_depth import (
    DEFAULT_DEPTH_MAX,
    DEFAULT_DEPTH_QUANTIZATION,
    DEFAULT_PNG_LEVEL,
    compressed_depth_fields,
)
from pyconnect.codecs.compressed_header import check_payload
from pyconnect.errors import DecodeError, EncodeError, type_name_of

_FORMATS = ("jpeg", "png", "compressedDepth")
_ENCODING_NAMES = {
    ("u1", 1): "mono8",
    ("u1", 3): "bgr8",
    ("u1", 4): "bgra8",
    ("u2", 1): "mono16",
    ("u2", 3): "bgr16",
    ("u2", 4): "bgra16",
}


def _imdecode(payload: npt.NDArray[np.uint8], what: str) -> npt.NDArray[Any]:
    import cv2

    if not len(payload):
        raise DecodeError(f"CompressedImage.data: cannot decode 0 bytes as {what}")
    check_payload(payload, what)  # before OpenCV allocates what the header claims
    image: npt.NDArray[Any] | None
    try:
        image = cv2.imdecode(payload, cv2.IMREAD_UNCHANGED)
    except cv2.error:
        image = None
    if image is None:
        raise DecodeError(f"CompressedImage.data: cannot decode {len(payload)} bytes as {what}")
    return image


def decode_compressed_image(msg: Any) -> npt.NDArray[Any]:
    """The pixels of a CompressedImage (jpeg, png or compressedDepth png)."""
    try:
        data = byte_view(msg.data)
        form = msg.format
    except (AttributeError, TypeError) as error:  # free until raised: a class, a Point()
        raise decode_failure(error, msg, "sensor_msgs/msg/CompressedImage") from None
    if type(form) is not str:  # str() made a class's property, an Int32's 5 a format
        form = _format_of(msg, form)
    if "compressedDepth" in form:
        return _decode_depth(data, form)
    what = "png" if "png" in form.lower() else "jpeg" if "jp" in form.lower() else repr(form)
    return _imdecode(data, what)


def _format_of(msg: Any, form: object) -> str:
    check_message_type(msg, "sensor_msgs/msg/CompressedImage")
    if isinstance(form, str):
        return str(form)  # numpy.str_
    raise DecodeError(f"CompressedImage.format: expected str, got {type_name_of(form)}")


def _decode_depth(data: npt.NDArray[np.uint8], form: str) -> npt.NDArray[Any]:
    if "rvl" in form:
        raise DecodeError(f"CompressedImage.format: {form!r} (rvl) is not supported")
    if len(data) < 12:
        raise DecodeError(
            f"CompressedImage.data: compressedDepth needs a 12-byte header, got {len(data)} bytes"
        )
    quant_a, quant_b = struct.unpack_from("<ff", data[:12].tobytes(), 4)
    inverse = _imdecode(data[12:], "compressedDepth png")
    # image_transport writes one 16-bit channel: 16UC1 depth as is, 32FC1 as quantised inverse
    # depth. Any other png would pass for depth with the wrong shape or type.
    if inverse.dtype != np.uint16 or inverse.ndim != 2:
        channels = 1 if inverse.ndim == 2 else inverse.shape[2]
        raise DecodeError(
            "CompressedImage.data: compressedDepth expects a 16-bit 1-channel png, got "
            f"{inverse.dtype.name} with {channels} channel{'s' if channels != 1 else ''}"
        )
    if not form.startswith("32FC1"):
        return inverse
    with np.errstate(divide="ignore"):
        depth: npt.NDArray[np.float32] = (
            quant_a / (inverse.astype(np.float32) - np.float32(quant_b))
        ).astype(np.float32)
    depth[inverse == 0] = np.nan
    return depth


def compressed_fields(
    value: Any, *, format: str = "jpeg", quality: int = 95, png_level: int = 3
) -> dict[str, Any]:
    """``format`` and ``data`` (bytes) of a CompressedImage holding ``value``."""
    import cv2

    if not isinstance(value, np.ndarray):
        raise EncodeError(f"CompressedImage: expected numpy.ndarray, got {type_name_of(value)}")
    channels = 1 if value.ndim == 2 else value.shape[2] if value.ndim == 3 else 0
    name = _ENCODING_NAMES.get((value.dtype.str[1:], channels))
    if name is None or (format == "jpeg" and (value.dtype != np.uint8 or channels == 4)):
        wanted = (
            "uint8 (H, W) or (H, W, 3)"
            if format == "jpeg"
            else "uint8 or uint16 (H, W), (H, W, 3) or (H, W, 4)"
        )
        raise EncodeError(
            f"CompressedImage: {format} expects {wanted}, got {value.dtype.name} of shape "
            f"{value.shape}"
        )
    if not value.size:
        raise EncodeError(f"CompressedImage: cannot compress an empty image (shape {value.shape})")
    if not value.dtype.isnative:
        value = value.astype(value.dtype.newbyteorder("="))
    try:
        if format == "jpeg":
            ok, encoded = cv2.imencode(".jpg", value, [cv2.IMWRITE_JPEG_QUALITY, quality])
        else:
            ok, encoded = cv2.imencode(".png", value, [cv2.IMWRITE_PNG_COMPRESSION, png_level])
    except cv2.error as error:  # e.g. a side beyond JPEG's 65,500 pixels
        raise EncodeError(
            f"CompressedImage: OpenCV could not encode {value.shape} as {format}: "
            f"{str(error).strip().splitlines()[-1]}"
        ) from None
    if not ok:
        raise EncodeError(f"CompressedImage: OpenCV could not encode {value.shape} as {format}")
    return {"format": f"{name}; {format} compressed {name}", "data": encoded.tobytes()}


class CompressedImageCodec(FieldsCodec):
    """CompressedImage ↔ ndarray; ``format`` is ``"jpeg"`` (with ``quality``), ``"png"`` or
    ``"compressedDepth"`` (uint16 or float32 depth; ``depth_max``, ``depth_quantization``).

    ``png_level`` defaults to 3 for png and to image_transport's 9 for compressedDepth.
    """

    msg_type = "sensor_msgs/msg/CompressedImage"
    lossless = False

    decode = staticmethod(decode_compressed_image)

    def __init__(
        self,
        *,
        format: str = "jpeg",
        quality: int = 95,
        png_level: int | None = None,
        depth_max: float = DEFAULT_DEPTH_MAX,
        depth_quantization: float = DEFAULT_DEPTH_QUANTIZATION,
    ) -> None:
        if format not in _FORMATS:
            raise EncodeError(
                f"CompressedImageCodec: format must be jpeg, png or compressedDepth, got {format!r}"
            )
        if png_level is None:
            png_level = DEFAULT_PNG_LEVEL if format == "compressedDepth" else 3
        if not 0 <= quality <= 100:
            raise EncodeError(f"CompressedImageCodec: quality must be 0-100, got {quality}")
        if not 0 <= png_level <= 9:
            raise EncodeError(f"CompressedImageCodec: png_level must be 0-9, got {png_level}")
        if not depth_max > 0 or not depth_quantization > 0:
            raise EncodeError(
                f"CompressedImageCodec: depth_max and depth_quantization must be > 0, got "
                f"{depth_max} and {depth_quantization}"
            )
        self.format = format
        self.quality = quality
        self.png_level = png_level
        self.depth_max = depth_max
        self.depth_quantization = depth_quantization

    def to_fields(self, value: Any) -> dict[str, Any]:
        if self.format == "compressedDepth":
            return compressed_depth_fields(
                value,
                depth_max=self.depth_max,
                depth_quantization=self.depth_quantization,
                png_level=self.png_level,
            )
        return compressed_fields(
            value, format=self.format, quality=self.quality, png_level=self.png_level
        )

    def __repr__(self) -> str:
        depth = (
            f", depth_max={self.depth_max}, depth_quantization={self.depth_quantization}"
            if self.format == "compressedDepth"
            else ""
        )
        return (
            f"CompressedImageCodec(format={self.format!r}, quality={self.quality}, "
            f"png_level={self.png_level}{depth})"
        )
