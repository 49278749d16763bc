"""Read a PNG's, JPEG's or TIFF's size from its header; refuse payloads too small for that size.

OpenCV allocates the whole image from the header before it reads the pixels, and libjpeg fills
what is missing: a 161-byte JPEG claiming 30000 x 20000 pixels costs 1.8 GB and a second. Each
format has a least number of payload bytes per pixel, so a header that claims more pixels than
its payload can hold is damage, found before any decoding:

- PNG: deflate expands at most 1032:1, and each pixel takes ``bit depth x samples`` bits of
  the inflated data;
- JPEG with Huffman coding: every 8x8 block of the full-resolution component costs at least
  one bit (its DC code), so at most 512 pixels per payload byte; arithmetic coding (rare) gets
  64 times more room;
- TIFF (compressed_image_transport's ``format=tiff``): the first image's size, samples and
  compression from its first directory, read as libtiff reads them (a directory that lists one
  of these tags twice, or in a type libtiff cannot read, is refused); deflate expands at most
  1032:1, LZW (12-bit codes) about 1365:1, PackBits 64:1, no compression 1:1, and any other
  scheme gets 32768:1 (JPEG's bound with arithmetic coding).
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
_TIFF_ORDERS = {b"II*\0": "<", b"MM\0*": ">"}
# TIFF compression code -> most bytes of pixels one payload byte can hold.
_TIFF_RATIOS = {1: 1, 5: 1400, 8: _DEFLATE_MAX_RATIO, 32946: _DEFLATE_MAX_RATIO, 32773: 64}
_TIFF_OTHER_RATIO = 32768
# TIFF field type -> struct code of the integer types libtiff reads these tags from: BYTE,
# SHORT, LONG, SBYTE, SSHORT, SLONG, IFD, LONG8, SLONG8, IFD8 (the 8-byte ones sit elsewhere
# even in classic TIFF).
_TIFF_INTEGER_CODES = {
    1: "B",
    3: "H",
    4: "I",
    6: "b",
    8: "h",
    9: "i",
    13: "I",
    16: "Q",
    17: "q",
    18: "Q",
}
_TIFF_TAG_NAMES = {
    256: "ImageWidth",
    257: "ImageLength",
    258: "BitsPerSample",
    259: "Compression",
    277: "SamplesPerPixel",
}
_TIFF_PER_SAMPLE = frozenset((258, 259))  # older TIFFs give one value per sample


def check_payload(payload: Any, what: str) -> tuple[int, int]:
    """(width, height) from a PNG, JPEG or TIFF header; ``DecodeError`` if it cannot hold them.

    Payloads that are none of these, or whose header is malformed, get OpenCV's answer for
    undecodable data: ``cannot decode N bytes as <what>``.
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
    elif head[:4] in _TIFF_ORDERS:
        tiff = _tiff_header(payload, _TIFF_ORDERS[head[:4]], what)
        if tiff is not None:
            width, height, bits, ratio = tiff
            if width * height * bits > 8 * ratio * len(payload):
                raise _too_small(payload, what, width, height)
            found = (width, height, bits)
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


def _tiff_header(payload: Any, order: str, what: str) -> tuple[int, int, int, int] | None:
    """Width, height, bits per pixel and the compression's largest expansion, from the first
    image file directory (TIFF 6.0's defaults for what it leaves out).

    Reads the tags as libtiff's ``TIFFReadDirectory`` does, so the size checked is the size
    OpenCV allocates: any integer type, one value (BitsPerSample and Compression may have one
    per sample; libtiff uses the first). A directory libtiff would read differently (a tag
    listed twice: libtiff keeps the first) or could not read is refused.
    """
    view = memoryview(payload).cast("B") if not isinstance(payload, bytes) else payload
    size = len(view)
    if size < 8:
        return None
    (directory,) = struct.unpack_from(order + "I", view, 4)
    if directory > size - 2:
        return None
    (entries,) = struct.unpack_from(order + "H", view, directory)
    if entries > (size - directory - 2) // 12:
        return None
    values = {256: 0, 257: 0, 258: 1, 259: 1, 277: 1}  # width, height, bits, compression, samples
    seen: set[int] = set()
    for pos in range(directory + 2, directory + 2 + 12 * entries, 12):
        (tag,) = struct.unpack_from(order + "H", view, pos)
        if tag not in values:
            continue
        if tag in seen:
            raise DecodeError(
                f"CompressedImage.data: the {what} directory lists tag {tag} "
                f"({_TIFF_TAG_NAMES[tag]}) more than once; expected it once"
            )
        seen.add(tag)
        values[tag] = _tiff_value(view, order, pos, what)
    width, height = values[256], values[257]
    if not width or not height:
        return None
    ratio = _TIFF_RATIOS.get(values[259], _TIFF_OTHER_RATIO)
    return width, height, max(values[258], 1) * max(values[277], 1), ratio


def _tiff_value(view: Any, order: str, pos: int, what: str) -> int:
    """The first value of the directory entry at ``pos``; ``DecodeError`` if libtiff could not
    read it, since a default in its place could understate the image's size."""
    tag, kind, count = struct.unpack_from(order + "HHI", view, pos)
    code = _TIFF_INTEGER_CODES.get(kind)
    name = f"tag {tag} ({_TIFF_TAG_NAMES[tag]})"
    if code is None:
        raise DecodeError(
            f"CompressedImage.data: {what} {name} has type {kind}; expected an integer type "
            f"(BYTE, SHORT, LONG, LONG8 or a signed one)"
        )
    if count != 1 and (count == 0 or tag not in _TIFF_PER_SAMPLE):
        raise DecodeError(f"CompressedImage.data: {what} {name} has {count} values; expected 1")
    item = struct.calcsize(order + code)
    at = pos + 8
    if count * item > 4:  # the values are elsewhere; libtiff uses the first
        (at,) = struct.unpack_from(order + "I", view, pos + 8)
        if at > len(view) - item:
            raise DecodeError(
                f"CompressedImage.data: {what} {name} points at byte {at}, past the "
                f"{len(view)} bytes"
            )
    (value,) = struct.unpack_from(order + code, view, at)
    if value < 0:
        raise DecodeError(f"CompressedImage.data: {what} {name} is {value}; expected >= 0")
    return int(value)
