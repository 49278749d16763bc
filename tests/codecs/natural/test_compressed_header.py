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


# TIFF field types -> struct codes, for writing directory entries in any integer type.
_TIFF_CODES = {1: "B", 3: "H", 4: "I", 5: "II", 6: "b", 8: "h", 9: "i", 16: "Q", 17: "q"}


def _tiff_directory(entries: list[tuple[int, int, int]], pad: int = 0) -> bytes:
    """A little-endian TIFF whose first directory lists ``(tag, type, value)`` entries, one value
    each: in the entry when it fits in four bytes, else right after the directory."""
    directory_end = 8 + 2 + 12 * len(entries) + 4
    out, tail = b"II*\0" + struct.pack("<IH", 8, len(entries)), b""
    for tag, kind, value in entries:
        packed = struct.pack("<" + _TIFF_CODES[kind], *([value] * len(_TIFF_CODES[kind])))
        if len(packed) > 4:
            out += struct.pack("<HHII", tag, kind, 1, directory_end + len(tail))
            tail += packed
        else:
            out += struct.pack("<HHI", tag, kind, 1) + packed.ljust(4, b"\0")
    return out + struct.pack("<I", 0) + tail + bytes(pad)


def _grey_entries(width: int, height: int) -> list[tuple[int, int, int]]:
    return [(256, 4, width), (257, 4, height), (258, 3, 8), (259, 3, 1), (277, 3, 1)]


@pytest.mark.parametrize("tag", [256, 257, 258, 259, 277])
def test_tiff_listing_a_size_tag_twice_is_refused(tag: int) -> None:
    # libtiff keeps the first of repeated tags; a check keeping the last saw a 20000 x 20000
    # image as 1 x 1, and OpenCV allocated 1.2 GB from 6 kB.
    entries = _grey_entries(64, 64)
    at = next(i for i, entry in enumerate(entries) if entry[0] == tag)
    entries.insert(at + 1, (tag, 3, 1))
    payload = _tiff_directory(entries, pad=64 * 64)
    with pytest.raises(DecodeError, match=rf"lists tag {tag} \(\w+\) more than once"):
        check_payload(payload, "tiff")


@pytest.mark.parametrize("kind", [1, 6, 8, 9, 16, 17])
def test_tiff_sizes_are_read_in_every_integer_type_libtiff_reads(kind: int) -> None:
    # 16 bits x 3 samples claimed in BYTE, SBYTE, SSHORT, SLONG, LONG8 or SLONG8: read as the
    # defaults (1 x 1 bit) they let 40 x 40 pixels pass in 300 bytes.
    entries = [(256, kind, 40), (257, kind, 40), (258, kind, 16), (259, kind, 1), (277, kind, 3)]
    payload = _tiff_directory(entries, pad=200)
    with pytest.raises(DecodeError) as error:
        check_payload(payload, "tiff")
    assert str(error.value) == (
        f"CompressedImage.data: a tiff header claims 40 x 40 pixels, more than "
        f"{len(payload)} bytes can hold"
    )
    small = _tiff_directory(entries, pad=40 * 40 * 6)
    assert check_payload(small, "tiff") == (40, 40)


def test_tiff_size_tag_in_a_type_libtiff_cannot_read_is_refused() -> None:
    # A RATIONAL BitsPerSample fails libtiff; assuming the default 1 would understate the size.
    entries = _grey_entries(40, 40)
    entries[2] = (258, 5, 16)
    with pytest.raises(DecodeError) as error:
        check_payload(_tiff_directory(entries, pad=300), "tiff")
    assert str(error.value) == (
        "CompressedImage.data: tiff tag 258 (BitsPerSample) has type 5; expected an integer "
        "type (BYTE, SHORT, LONG, LONG8 or a signed one)"
    )
    entries = _grey_entries(40, 40)
    entries[4] = (277, 3, 3)
    payload = _tiff_directory(entries, pad=300)
    payload = payload.replace(struct.pack("<HHI", 277, 3, 1), struct.pack("<HHI", 277, 3, 2))
    with pytest.raises(DecodeError, match=r"tag 277 \(SamplesPerPixel\) has 2 values; expected 1"):
        check_payload(payload, "tiff")


@pytest.mark.parametrize(
    ("dtype", "channels"), [(np.uint8, 1), (np.uint8, 3), (np.uint8, 4), (np.uint16, 3)]
)
def test_tiffs_opencv_writes_still_decode(dtype: type[np.generic], channels: int) -> None:
    pixels = (np.arange(6 * 5 * channels) % 200).astype(dtype).reshape(6, 5, channels)
    payload = cv2.imencode(".tiff", pixels)[1].tobytes()
    assert check_payload(payload, "tiff") == (5, 6)
    decoded = decode_compressed_image(_compressed("tiff", payload))
    assert np.array_equal(decoded.reshape(pixels.shape), pixels)
