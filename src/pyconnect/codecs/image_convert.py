"""``convert(image, desired_encoding, source_encoding=...)``: cv_bridge's ``desired_encoding``.

Converts a decoded Image array between encodings with OpenCV, by the one ``cvtColor`` code
cv_bridge uses for each pair: bayer to mono, bgr and rgb (not to 4 channels, which cv_bridge
refuses); yuv422 (UYVY), yuv422_yuy2 (YUYV), nv12 and nv21 to mono, bgr, rgb, bgra and rgba;
nv24 (which OpenCV lacks) through bgr; between mono, bgr, rgb, bgra and rgba; and between depths
as cv_bridge's ``convertTo`` does: 16 → 8 bits scales by 255/65535, 8 → 16 bits by 257, other
depth changes do not scale, and every change to an integer depth rounds half to even and
saturates (``32FC1`` 300.0 → ``8UC1`` 255, -1.0 → 0). A generic ``…C…`` source converts only to a
``…C…`` encoding with the same channel count; a named source converts to a ``…C…`` encoding of
its channel count. ``"passthrough"`` returns the image unchanged.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from pyconnect.codecs.image_encodings import (
    NAMED_ENCODINGS,
    UnknownEncodingError,
    pixel_format,
)
from pyconnect.errors import CodecError

__all__ = ["ConversionError", "convert"]


class ConversionError(CodecError):
    """An image cannot be converted between two encodings."""


# The colour family of each named encoding (the part cvtColor cares about).
_FAMILY = {
    "mono8": "GRAY",
    "mono16": "GRAY",
    "bgr8": "BGR",
    "bgr16": "BGR",
    "rgb8": "RGB",
    "rgb16": "RGB",
    "bgra8": "BGRA",
    "bgra16": "BGRA",
    "rgba8": "RGBA",
    "rgba16": "RGBA",
}
# OpenCV names the Bayer pattern by the 2x2 block starting at the second row and column.
_BAYER = {"rggb": "BayerBG", "bggr": "BayerRG", "gbrg": "BayerGR", "grbg": "BayerGB"}
_YUV = {
    "yuv422": "UYVY",
    "uyvy": "UYVY",
    "yuv422_yuy2": "YUY2",
    "yuyv": "YUY2",
    "nv21": "NV21",
    "nv12": "NV12",
}


_CHANNELS = {"GRAY": 1, "BGR": 3, "RGB": 3, "BGRA": 4, "RGBA": 4}
# What OpenCV asks of a YUV image's size, for the error when it refuses one.
_YUV_NEEDS = {
    "UYVY": "an even width",
    "YUY2": "an even width",
    "NV21": "an even width and height",
    "NV12": "an even width and height",
}


def _cvt(
    image: npt.NDArray[Any], code: str, wanted: str, pair: tuple[str, str], rows: int
) -> npt.NDArray[Any]:
    """``cv2.cvtColor`` by code name, giving an image of ``rows`` rows in the family ``wanted``.

    OpenCV refuses empty images, so they convert to an empty array without it; any other
    refusal (an odd width for 4:2:2) is a ``ConversionError`` naming the pair and the shape.
    """
    import cv2

    channels = _CHANNELS[wanted]
    if not image.size:
        width = image.shape[1] if image.ndim > 1 else 0
        return np.empty((rows, width) if channels == 1 else (rows, width, channels), image.dtype)
    try:
        converted: npt.NDArray[Any] = cv2.cvtColor(np.ascontiguousarray(image), _code(code))
    except cv2.error as error:
        need = _YUV_NEEDS.get(code.rsplit("_", 1)[-1])
        raise ConversionError(
            f"convert: OpenCV cannot convert [{pair[0]}] to [{pair[1]}] for an array of shape "
            f"{image.shape}" + (f" ({pair[0]} needs {need})" if need else "")
        ) from error
    return converted


def _code(name: str) -> int:
    import cv2

    code: int = getattr(cv2, name)
    return code


def _in_family(image: npt.NDArray[Any], source: str, wanted: str, target: str) -> npt.NDArray[Any]:
    """``image`` (of encoding ``source``) in the colour family ``wanted`` (GRAY, BGR, RGB, BGRA,
    RGBA), by the one OpenCV conversion cv_bridge uses for the pair."""
    pair = (source, target)
    rows = image.shape[0] if image.ndim else 0
    if source in _FAMILY:
        family = _FAMILY[source]
        if family == wanted:
            return image
        return _cvt(image, f"COLOR_{family}2{wanted}", wanted, pair, rows)
    if source.startswith("bayer_"):
        if wanted not in ("GRAY", "BGR", "RGB"):  # cv_bridge has no Bayer to 4 channels
            raise ConversionError(f"convert: Unsupported conversion from [{source}] to [{target}]")
        pattern = _BAYER[source[6:10]]
        return _cvt(image, f"COLOR_{pattern}2{wanted}", wanted, pair, rows)
    if source in _YUV:
        layout = _YUV[source]
        image_rows = rows * 2 // 3 if layout.startswith("NV") else rows
        return _cvt(image, f"COLOR_YUV2{wanted}_{layout}", wanted, pair, image_rows)
    if source == "nv24":  # OpenCV has no NV24 code: YUV 4:4:4 planes, then BGR
        if image.ndim != 2 or rows % 3:
            raise ConversionError(
                f"convert: [nv24] expects a 2-D array of 3 * height rows, got shape {image.shape}"
            )
        rows //= 3
        luma = image[:rows]
        # V4L2's NV24: Cb (U) first, then Cr (V), as in nv12.
        chroma = image[rows:].reshape(rows, image.shape[1], 2)
        yuv = np.dstack((luma, chroma[..., 0], chroma[..., 1]))
        bgr = _cvt(yuv, "COLOR_YUV2BGR", "BGR", pair, rows)
        return bgr if wanted == "BGR" else _cvt(bgr, f"COLOR_BGR2{wanted}", wanted, pair, rows)
    raise ConversionError(f"convert: no colour conversion from {source!r}")


# cv_bridge scales by bit depth (enc::bitDepth), whatever the signedness: 8 ↔ 16 bits only.
_SCALE = {(1, 2): 65535.0 / 255.0, (2, 1): 255.0 / 65535.0}
_INT32_MIN = -(2**31)


def _depth(image: npt.NDArray[Any], target: np.dtype[Any]) -> npt.NDArray[Any]:
    """``image`` in ``target``'s depth as OpenCV's ``convertTo`` gives it (cv_bridge's scale)."""
    if image.dtype == target:
        return image
    if target.kind == "f":
        # No scale reaches a float depth; float64 → float32 overflows to ±inf as in OpenCV,
        # and a signalling NaN is no error here.
        with np.errstate(over="ignore", invalid="ignore"):
            return image.astype(target)
    if image.dtype == np.uint8 and target == np.uint16:
        widened: npt.NDArray[np.uint16] = image.astype(np.uint16) * np.uint16(257)
        return widened
    bounds = np.iinfo(target)
    scale = _SCALE.get((image.dtype.itemsize, target.itemsize), 1.0)
    if image.dtype.kind != "f" and scale == 1.0:
        source = np.iinfo(image.dtype)
        if source.min < bounds.min or source.max > bounds.max:
            image = np.clip(image, max(source.min, bounds.min), min(source.max, bounds.max))
        return image.astype(target)
    values: npt.NDArray[np.floating[Any]]
    if image.dtype.kind == "f":
        # OpenCV rounds through int32 (cvRound); on x86 NaN, ±inf and anything outside int32
        # come back as INT32_MIN, which then saturates: NaN → 0 in 8UC1, -128 in 8SC1.
        with np.errstate(invalid="ignore"):  # a signalling NaN
            values = np.rint(image)
            values[~((values >= _INT32_MIN) & (values < -_INT32_MIN))] = _INT32_MIN
    else:
        # 8 ↔ 16 bits: exact in float64, and x * 255/65535 is never within 1e-3 of a half.
        values = np.rint(image * scale)
        source = np.iinfo(image.dtype)
        if bounds.min <= round(source.min * scale) and round(source.max * scale) <= bounds.max:
            return values.astype(target)  # mono16 → mono8: nothing to saturate
    np.clip(values, bounds.min, bounds.max, out=values)
    return values.astype(target)


def convert(
    image: npt.NDArray[Any], desired_encoding: str, *, source_encoding: str
) -> npt.NDArray[Any]:
    """``image`` (decoded from ``source_encoding``) in ``desired_encoding``; a new array."""

    if desired_encoding in ("passthrough", source_encoding):
        return image
    try:
        source_format = pixel_format(source_encoding)
        target_format = pixel_format(desired_encoding)
    except UnknownEncodingError as error:
        raise ConversionError(f"convert: {error}") from None
    if not image.dtype.isnative:
        image = image.astype(image.dtype.newbyteorder("="))
    generic_source = source_encoding not in NAMED_ENCODINGS
    if generic_source and desired_encoding in NAMED_ENCODINGS:
        # cv_bridge's rule and words: a …C… image has no colour to convert.
        raise ConversionError(
            f"convert: [{source_encoding}] is not a color format. but [{desired_encoding}] is. "
            "The conversion does not make sense"
        )
    if generic_source or desired_encoding not in NAMED_ENCODINGS:
        if source_format.channels != target_format.channels:
            raise ConversionError(
                f"convert: cannot convert {source_encoding!r} ({source_format.channels} "
                f"channels) to {desired_encoding!r} ({target_format.channels} channels)"
            )
        return _depth(image, target_format.dtype)
    if desired_encoding not in _FAMILY:
        raise ConversionError(
            f"convert: cannot convert to {desired_encoding!r} (targets: "
            f"{', '.join(_FAMILY)} and the …C… encodings)"
        )
    colour = _in_family(image, source_encoding, _FAMILY[desired_encoding], desired_encoding)
    return _depth(colour, target_format.dtype)
