"""The pixel layout of every ``sensor_msgs/Image`` encoding cv_bridge knows: dtype, channels, rows.

Most encodings store ``height`` rows of ``width`` pixels. The semi-planar YUV encodings store
more rows than the image has: ``nv21``/``nv12`` (4:2:0) hold ``height * 3/2`` rows of ``width``
bytes (a Y plane, then interleaved chroma) and ``nv24`` (4:4:4) holds ``height * 3`` rows. Their
natural value is that buffer as a 2-D uint8 array of all rows: the layout OpenCV's ``cvtColor``
reads (``COLOR_YUV2BGR_NV21``). ``nv24`` (V4L2's NV24) is a Y plane of ``height`` rows of
``step`` bytes, then interleaved chroma, Cb (U) first, of ``height`` rows of ``2 * step`` bytes
(twice a luma row, padding included); its natural value is the Y rows, then each chroma row cut in
two rows of ``width`` bytes. Jazzy's ``sensor_msgs`` counts 2 channels for ``nv21``/``nv24`` and
cv_bridge refuses both; pyconnect keeps the single-channel buffer OpenCV reads (the count later
``sensor_msgs`` gives ``nv21``). rosbags-image instead reads ``height`` rows only, so the two
agree on the packed encodings and differ on these.

Generic encodings follow cv_bridge's ``getCvType``: ``{depth}C{channels}`` with 1 to 512
channels (OpenCV's ``CV_CN_MAX``), or a bare depth (``32F``) for one channel.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from pyconnect.errors import CodecError


@dataclass(frozen=True)
class PixelFormat:
    """How one encoding lays out pixels: element dtype, channels and buffer rows per image row."""

    encoding: str
    dtype: np.dtype[np.generic]
    channels: int
    # Buffer rows per image row: 1, except for the semi-planar YUV encodings.
    rows_per_row: Fraction = Fraction(1)

    @property
    def pixel_bytes(self) -> int:
        return self.dtype.itemsize * self.channels


_U8, _U16 = np.dtype(np.uint8), np.dtype(np.uint16)

_NAMED: dict[str, tuple[np.dtype[np.generic], int, Fraction]] = {
    "mono8": (_U8, 1, Fraction(1)),
    "mono16": (_U16, 1, Fraction(1)),
    "bgr8": (_U8, 3, Fraction(1)),
    "rgb8": (_U8, 3, Fraction(1)),
    "bgra8": (_U8, 4, Fraction(1)),
    "rgba8": (_U8, 4, Fraction(1)),
    "bgr16": (_U16, 3, Fraction(1)),
    "rgb16": (_U16, 3, Fraction(1)),
    "bgra16": (_U16, 4, Fraction(1)),
    "rgba16": (_U16, 4, Fraction(1)),
    "bayer_rggb8": (_U8, 1, Fraction(1)),
    "bayer_bggr8": (_U8, 1, Fraction(1)),
    "bayer_gbrg8": (_U8, 1, Fraction(1)),
    "bayer_grbg8": (_U8, 1, Fraction(1)),
    "bayer_rggb16": (_U16, 1, Fraction(1)),
    "bayer_bggr16": (_U16, 1, Fraction(1)),
    "bayer_gbrg16": (_U16, 1, Fraction(1)),
    "bayer_grbg16": (_U16, 1, Fraction(1)),
    # yuv422 is UYVY (sensor_msgs' name); yuv422_yuy2 is YUYV. Two bytes per pixel.
    "yuv422": (_U8, 2, Fraction(1)),
    "uyvy": (_U8, 2, Fraction(1)),
    "yuv422_yuy2": (_U8, 2, Fraction(1)),
    "yuyv": (_U8, 2, Fraction(1)),
    "nv21": (_U8, 1, Fraction(3, 2)),
    "nv12": (_U8, 1, Fraction(3, 2)),
    "nv24": (_U8, 1, Fraction(3)),
}

_DEPTHS: dict[str, np.dtype[np.generic]] = {
    "8U": np.dtype(np.uint8),
    "8S": np.dtype(np.int8),
    "16U": np.dtype(np.uint16),
    "16S": np.dtype(np.int16),
    "32S": np.dtype(np.int32),
    "32F": np.dtype(np.float32),
    "64F": np.dtype(np.float64),
}
_DEPTH_OF_DTYPE = {dtype.str[1:]: depth for depth, dtype in _DEPTHS.items()}
# At most three digits and no leading zero: one spelling per channel count, and no digit run
# long enough for int() to refuse (cv_bridge's atoi reads any).
_GENERIC = re.compile(r"(8U|8S|16U|16S|32S|32F|64F)(?:C([1-9][0-9]{0,2}))?")
MAX_CHANNELS = 512  # OpenCV's CV_CN_MAX
_SHOWN_LENGTH = 64  # characters of an unknown encoding an error quotes

NAMED_ENCODINGS: tuple[str, ...] = tuple(_NAMED)
# The common generic encodings (1-4 channels), to enumerate; pixel_format accepts more.
GENERIC_ENCODINGS: tuple[str, ...] = tuple(
    f"{depth}C{channels}" for depth in _DEPTHS for channels in range(1, 5)
)
ALL_ENCODINGS: tuple[str, ...] = NAMED_ENCODINGS + GENERIC_ENCODINGS


class UnknownEncodingError(CodecError):
    """An image encoding pyconnect does not know."""


def pixel_format(encoding: str) -> PixelFormat:
    """The layout of ``encoding``; raises ``UnknownEncodingError`` naming it otherwise."""
    named = _NAMED.get(encoding)
    if named is not None:
        return PixelFormat(encoding, named[0], named[1], named[2])
    match = _GENERIC.fullmatch(encoding)
    if match is None:
        raise UnknownEncodingError(
            f"unknown image encoding {_shown(encoding)} (known: {', '.join(NAMED_ENCODINGS)} "
            f"and {{8U,8S,16U,16S,32S,32F,64F}} alone or with C{{1..{MAX_CHANNELS}}})"
        )
    channels = 1 if match.group(2) is None else int(match.group(2))
    if not 1 <= channels <= MAX_CHANNELS:
        raise UnknownEncodingError(
            f"image encoding {encoding!r}: expected 1 to {MAX_CHANNELS} channels (OpenCV's "
            f"CV_CN_MAX), got {channels}"
        )
    return PixelFormat(encoding, _DEPTHS[match.group(1)], channels)


def _shown(encoding: str) -> str:
    """``encoding`` quoted for an error, its start only when long: it comes from the data, and a
    hostile one can be megabytes."""
    if len(encoding) <= _SHOWN_LENGTH:
        return repr(encoding)
    return f"{encoding[:_SHOWN_LENGTH]!r}… ({len(encoding)} characters)"


def generic_encoding(dtype: np.dtype[np.generic], channels: int) -> str | None:
    """The ``{depth}C{channels}`` name for a dtype, or None when OpenCV has no such depth or
    channel count."""
    depth = _DEPTH_OF_DTYPE.get(dtype.str[1:])
    if depth is None or not 1 <= channels <= MAX_CHANNELS:
        return None
    return f"{depth}C{channels}"


def infer_encoding(dtype: np.dtype[np.generic], channels: int) -> str | None:
    """The default encoding of an array: mono8, bgr8, bgra8, mono16, 32FC1, else ``…C…``."""
    kind = dtype.str[1:]
    if kind == "u1":
        named = {1: "mono8", 3: "bgr8", 4: "bgra8"}.get(channels)
        if named is not None:
            return named
    elif kind == "u2" and channels == 1:
        return "mono16"
    return generic_encoding(dtype, channels)
