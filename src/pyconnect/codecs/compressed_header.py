"""Read a PNG's or JPEG's size from its header, and refuse payloads too small for that size.

OpenCV allocates the whole image from the header before it reads the pixels, and libjpeg fills
what is missing: a 161-byte JPEG claiming 30000 x 20000 pixels costs 1.8 GB and a second. Each
format has a least number of payload bytes per pixel, so a header that claims more pixels than
its payload can hold is damage, found before any decoding:

- PNG: deflate expands at most 1032:1, and each pixel takes ``bit depth x samples`` bits of
  the inflated data;
- JPEG with Huffman coding: every 8x8 block of the full-resolution component costs at least
  one bit (its DC code), so at most 512 pixels per payload byte; arithmetic coding (rare) gets
  64 times more room.
"""

from __future__ import annotations

import struct
from typing import Any

from pyconnect.errors import DecodeError

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_DEFLATE_MAX_RATIO = 1032
_PNG_SAMPLES = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}  # colour type -> samples per pixel
_JPEG_PIXELS_PER_BYTE = 512
_ARITHMETIC_SOF = frozenset((0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF))
_NO_LENGTH = frozenset((0x01, *range(0xD0, 0xD8)))  # TEM and RSTn stand alone


def check_payload(payload: Any, what: str) -> tuple[int, int]:
    """(width, height) from a PNG or JPEG header; ``DecodeError`` if it cannot hold them.

    Payloads that are neither PNG nor JPEG, or whose header is malformed, get OpenCV's
    answer for undecodable data: ``cannot decode N bytes as <what>``.
    """
    head = bytes(payload[:8])
    found: tuple[int, int, int] | None = None
    if head == PNG_SIGNATURE:
        found = _png_header(payload)
        if found is not None:
            width, height, bits = found
            if width * height * bits > 8 * _DEFLATE_MAX_RATIO * len(payload):
                raise _too_small(payload, what, width, height)
    elif head[:2] == b"\xff\xd8":
        found = _jpeg_header(payload)
        if found is not None:
            width, height, arithmetic = found
            per_byte = _JPEG_PIXELS_PER_BYTE * (64 if arithmetic else 1)
            if width * height > per_byte * len(payload):
                raise _too_small(payload, what, width, height)
    if found is None:
        raise DecodeError(f"CompressedImage.data: cannot decode {len(payload)} bytes as {what}")
    return found[0], found[1]


def _too_small(payload: Any, what: str, width: int, height: int) -> DecodeError:
    return DecodeError(
        f"CompressedImage.data: a {what} header claims {width} x {height} pixels, more than "
        f"{len(payload)} bytes can hold"
    )


def _png_header(payload: Any) -> tuple[int, int, int] | None:
    """Width, height and bits per pixel from the IHDR chunk that must come first."""
    ihdr = bytes(payload[8:29])
    if len(ihdr) < 21 or ihdr[4:8] != b"IHDR":
        return None
    width, height, depth, colour = struct.unpack(">IIBB", ihdr[8:18])
    samples = _PNG_SAMPLES.get(colour)
    if samples is None or depth not in (1, 2, 4, 8, 16) or not width or not height:
        return None
    if not _png_chunks_fit(payload):
        return None
    return width, height, depth * samples


def _png_chunks_fit(payload: Any) -> bool:
    """Whether every chunk's length stays inside the payload.

    OpenCV 4.11's PNG reader allocates a chunk's claimed length before reading it: one
    flipped length byte costs gigabytes and seconds.
    """
    view = memoryview(payload).cast("B") if not isinstance(payload, bytes) else payload
    size = len(view)
    pos = 8
    while pos + 12 <= size:
        (length,) = struct.unpack_from(">I", view, pos)
        if length > size - pos - 12:
            return False
        if bytes(view[pos + 4 : pos + 8]) == b"IEND":
            return True
        pos += 12 + length
    return pos >= size


def _jpeg_header(payload: Any) -> tuple[int, int, int] | None:
    """Width, height and whether it is arithmetic-coded, from the first SOF marker."""
    data = bytes(payload[: 1 << 20])  # markers before the frame header are small
    pos = 2
    while pos + 4 <= len(data):
        if data[pos] != 0xFF:
            break
        marker = data[pos + 1]
        if marker == 0xFF:  # fill byte
            pos += 1
            continue
        if marker in _NO_LENGTH:
            pos += 2
            continue
        (length,) = struct.unpack_from(">H", data, pos + 2)
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):
            if pos + 9 > len(data) or length < 8:
                break
            height, width = struct.unpack_from(">HH", data, pos + 5)
            if not width or not height:  # a height given later (DNL) is not supported
                return None
            return width, height, int(marker in _ARITHMETIC_SOF)
        if marker == 0xDA or length < 2:  # scan data before any frame header
            break
        pos += 2 + length
    return None
