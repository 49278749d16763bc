"""``check_payload``: sizes from PNG, JPEG and TIFF headers, and payloads too small for them."""

from __future__ import annotations

import struct
from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from pyconnect.codecs.compressed_header import check_payload
from pyconnect.codecs.compressed_image import decode_compressed_image
from pyconnect.errors import DecodeError


def _tiff(order: str, pixels: np.ndarray, *, claimed: tuple[int, int] | None = None) -> bytes:
    """An uncompressed 8-bit grey TIFF in byte order ``order`` (``<`` or ``>``), one strip."""
    height, width = pixels.shape if claimed is None else claimed
    entries = [
        (256, 4, 1, width),  # ImageWidth, LONG
        (257, 4, 1, height),  # ImageLength, LONG
        (258, 3, 1, 8),  # BitsPerSample
        (259, 3, 1, 1),  # Compression: none
        (262, 3, 1, 1),  # PhotometricInterpretation: BlackIsZero
        (273, 4, 1, 8),  # StripOffsets: right after the header
        (277, 3, 1, 1),  # SamplesPerPixel
        (278, 4, 1, height),  # RowsPerStrip
        (279, 4, 1, pixels.size),  # StripByteCounts
    ]
    directory = 8 + pixels.size
    out = (b"II*\0" if order == "<" else b"MM\0*") + struct.pack(order + "I", directory)
    out += pixels.tobytes() + struct.pack(order + "H", len(entries))
    for tag, kind, count, value in entries:
        # A SHORT sits in the first two bytes of the value field.
        packed = (
            struct.pack(order + "H", value) + bytes(2)
            if kind == 3
            else struct.pack(order + "I", value)
        )
        out += struct.pack(order + "HHI", tag, kind, count) + packed
    return out + struct.pack(order + "I", 0)


def _compressed(form: str, payload: bytes) -> SimpleNamespace:
    return SimpleNamespace(format=form, data=np.frombuffer(payload, np.uint8))


def test_tiff_decodes_as_opencv_reads_it() -> None:
    # compressed_image_transport publishes format=tiff; OpenCV (cv_bridge) decodes it.
    red = np.zeros((8, 8, 3), np.uint8)
    red[..., 2] = 255
    payload = cv2.imencode(".tiff", red)[1].tobytes()
    assert check_payload(np.frombuffer(payload, np.uint8), "tiff") == (8, 8)
    decoded = decode_compressed_image(_compressed("bgr8; tiff compressed ", payload))
    assert np.array_equal(decoded, red)
    grey = np.arange(12, dtype=np.uint8).reshape(3, 4)
    for order in "<>":
        payload = _tiff(order, grey)
        assert check_payload(payload, "tiff") == (4, 3)
        assert np.array_equal(decode_compressed_image(_compressed("mono8; tiff", payload)), grey)


def test_tiff_claiming_more_pixels_than_its_bytes_hold_is_refused() -> None:
    payload = _tiff(">", np.zeros((2, 2), np.uint8), claimed=(20000, 30000))
    with pytest.raises(DecodeError) as error:
        check_payload(payload, "tiff")
    assert str(error.value) == (
        f"CompressedImage.data: a tiff header claims 30000 x 20000 pixels, more than "
        f"{len(payload)} bytes can hold"
    )


def test_unknown_or_broken_headers_cannot_be_decoded() -> None:
    broken_directory = b"II*\0" + struct.pack("<I", 1000) + bytes(8)
    for payload in (b"GIF89a" + bytes(20), broken_directory, b"MM\0*"):
        with pytest.raises(DecodeError) as error:
            check_payload(payload, "'rgb8; gif'")
        assert str(error.value) == (
            f"CompressedImage.data: cannot decode {len(payload)} bytes as 'rgb8; gif'"
        )
