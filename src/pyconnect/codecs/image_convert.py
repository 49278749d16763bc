"""``convert(image, desired_encoding, source_encoding=...)``: cv_bridge's ``desired_encoding``.

Converts a decoded Image array between encodings with OpenCV: bayer, yuv422 (UYVY), yuv422_yuy2
(YUYV), nv12/nv21 and nv24 to colour; between mono, bgr, rgb, bgra and rgba; and between 8 and
16 bits (16 → 8 scales by 255/65535 and rounds, 8 → 16 multiplies by 257). The generic
``…C…`` encodings convert only to an encoding with the same channel count (a dtype cast).
``"passthrough"`` returns the image unchanged.
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


def _code(name: str) -> int:
    import cv2

    code: int = getattr(cv2, name)
    return code


def _to_bgr_family(image: npt.NDArray[Any], source: str) -> tuple[npt.NDArray[Any], str]:
    """``image`` in one of GRAY/BGR/RGB/BGRA/RGBA, and which."""
    import cv2

    if source in _FAMILY:
        return image, _FAMILY[source]
    if source.startswith("bayer_"):
        pattern = _BAYER[source[6:10]]
        return cv2.cvtColor(np.ascontiguousarray(image), _code(f"COLOR_{pattern}2BGR")), "BGR"
    if source in _YUV:
        return (
            cv2.cvtColor(np.ascontiguousarray(image), _code(f"COLOR_YUV2BGR_{_YUV[source]}")),
            "BGR",
        )
    if source == "nv24":
        rows = image.shape[0] // 3
        luma = image[:rows]
        chroma = image[rows:].reshape(rows, image.shape[1], 2)  # interleaved V, U
        yuv = np.dstack((luma, chroma[..., 1], chroma[..., 0]))
        return cv2.cvtColor(yuv, cv2.COLOR_YUV2BGR), "BGR"
    raise ConversionError(f"convert: no colour conversion from {source!r}")


def _depth(image: npt.NDArray[Any], target: np.dtype[Any]) -> npt.NDArray[Any]:
    if image.dtype == target:
        return image
    if image.dtype == np.uint16 and target == np.uint8:
        return np.rint(image * (255.0 / 65535.0)).astype(np.uint8)
    if image.dtype == np.uint8 and target == np.uint16:
        widened: npt.NDArray[np.uint16] = image.astype(np.uint16) * np.uint16(257)
        return widened
    return image.astype(target)


def convert(
    image: npt.NDArray[Any], desired_encoding: str, *, source_encoding: str
) -> npt.NDArray[Any]:
    """``image`` (decoded from ``source_encoding``) in ``desired_encoding``; a new array."""
    import cv2

    if desired_encoding in ("passthrough", source_encoding):
        return image
    try:
        source_format = pixel_format(source_encoding)
        target_format = pixel_format(desired_encoding)
    except UnknownEncodingError as error:
        raise ConversionError(f"convert: {error}") from None
    if not image.dtype.isnative:
        image = image.astype(image.dtype.newbyteorder("="))
    generic = {source_encoding, desired_encoding} - set(NAMED_ENCODINGS)
    if generic:
        if source_format.channels != target_format.channels or (
            desired_encoding not in _FAMILY and desired_encoding not in generic
        ):
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
    colour, family = _to_bgr_family(image, source_encoding)
    wanted = _FAMILY[desired_encoding]
    if family != wanted:
        colour = cv2.cvtColor(np.ascontiguousarray(colour), _code(f"COLOR_{family}2{wanted}"))
    return _depth(colour, target_format.dtype)
