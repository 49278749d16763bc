"""Encode depth images as image_transport's ``compressedDepth``: a 12-byte header, then a PNG.

What ``compressed_depth_image_transport`` (ROS 2 Jazzy) writes, with its defaults
(``depth_max`` 10 m, ``depth_quantization`` 100, ``png_level`` 9):

- ``16UC1`` (uint16 millimetres): values above ``depth_max`` x 1000 become 0, the rest are
  written unchanged as a 16-bit PNG; the header's two parameters are 0.
- ``32FC1`` (float32 metres): inverse-depth quantisation, ``A = q (q + 1)``,
  ``B = 1 - A / depth_max``, each pixel ``d`` in (0, depth_max) becomes the uint16
  ``A / d + B`` and everything else (NaN, 0, beyond ``depth_max``) becomes 0, which decodes to
  NaN; ``A`` and ``B`` go into the header so any reader can invert it.

The header is ``int32 format`` (0, inverse depth) then ``float32 depthParam[2]``, little-endian.
The format string is ``"<encoding>; compressedDepth png"``.
"""

from __future__ import annotations

import struct
from typing import Any

import numpy as np
import numpy.typing as npt

from pyconnect.errors import EncodeError, type_name_of

DEFAULT_DEPTH_MAX = 10.0
DEFAULT_DEPTH_QUANTIZATION = 100.0
DEFAULT_PNG_LEVEL = 9
_INV_DEPTH = 0


def quantisation(depth_max: float, depth_quantization: float) -> tuple[float, float]:
    """image_transport's (A, B), computed in float32 as its C++ code does."""
    z0 = np.float32(depth_quantization)
    quant_a = np.float32(z0 * (z0 + np.float32(1.0)))
    quant_b = np.float32(np.float32(1.0) - quant_a / np.float32(depth_max))
    return float(quant_a), float(quant_b)


def compressed_depth_fields(
    value: Any,
    *,
    depth_max: float = DEFAULT_DEPTH_MAX,
    depth_quantization: float = DEFAULT_DEPTH_QUANTIZATION,
    png_level: int = DEFAULT_PNG_LEVEL,
) -> dict[str, Any]:
    """``format`` and ``data`` of a compressedDepth CompressedImage holding ``value``."""
    import cv2

    if not isinstance(value, np.ndarray):
        raise EncodeError(f"CompressedImage: expected numpy.ndarray, got {type_name_of(value)}")
    shape = value.shape
    if value.ndim == 3 and shape[2] == 1:
        value = value[:, :, 0]
    if value.ndim != 2 or value.dtype.kind + str(value.dtype.itemsize) not in ("u2", "f4"):
        raise EncodeError(
            f"CompressedImage: compressedDepth expects uint16 (16UC1) or float32 (32FC1) of "
            f"shape (H, W), got {value.dtype.name} of shape {shape}"
        )
    if value.size == 0:
        raise EncodeError(f"CompressedImage: compressedDepth needs pixels, got shape {shape}")
    if value.dtype.kind == "u":
        encoding, params = "16UC1", (0.0, 0.0)
        depth = value.astype(np.uint16, copy=True)  # native order, and never the caller's array
        depth[depth > np.uint16(min(int(depth_max * 1000.0), 65535))] = 0
        pixels: npt.NDArray[np.uint16] = depth
    else:
        encoding = "32FC1"
        params = quantisation(depth_max, depth_quantization)
        pixels = _inverse_depth(value.astype(np.float32), depth_max, params)
    ok, encoded = cv2.imencode(".png", pixels, [cv2.IMWRITE_PNG_COMPRESSION, png_level])
    if not ok:
        raise EncodeError(f"CompressedImage: OpenCV could not encode {shape} as compressedDepth")
    header = struct.pack("<iff", _INV_DEPTH, *params)
    return {"format": f"{encoding}; compressedDepth png", "data": header + encoded.tobytes()}


def _inverse_depth(
    depth: npt.NDArray[np.float32], depth_max: float, params: tuple[float, float]
) -> npt.NDArray[np.uint16]:
    quant_a, quant_b = np.float32(params[0]), np.float32(params[1])
    valid = np.isfinite(depth) & (depth > 0) & (depth < np.float32(depth_max))
    inverse = np.zeros(depth.shape, np.uint16)
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        scaled = quant_a / depth[valid] + quant_b
    # C++ converts float to unsigned short by truncation; values past 65535 saturate here.
    inverse[valid] = np.clip(scaled, 0, 65535).astype(np.uint16)
    return inverse
