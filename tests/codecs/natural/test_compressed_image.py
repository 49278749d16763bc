"""CompressedImage ↔ ndarray with OpenCV: jpeg, png (8 and 16 bit), compressedDepth, errors."""

from __future__ import annotations

import struct

import cv2
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from pyconnect import codecs
from pyconnect.codecs.compressed_image import CompressedImageCodec, decode_compressed_image
from pyconnect.errors import DecodeError, EncodeError
from tests.codecs.natural.helpers import EXAMPLES, same, wire_view

CompressedImage = pytest.importorskip("sensor_msgs.msg").CompressedImage


@st.composite
def png_images(draw: st.DrawFn) -> np.ndarray:
    dtype = draw(st.sampled_from([np.uint8, np.uint16]))
    channels = draw(st.sampled_from([1, 3, 4]))
    shape = (draw(st.integers(1, 6)), draw(st.integers(1, 7)))
    return draw(hnp.arrays(dtype, shape if channels == 1 else (*shape, channels)))


@EXAMPLES
@given(png_images())
def test_png_round_trip_is_exact_and_16_bit_stays_16_bit(image: np.ndarray) -> None:
    codec = CompressedImageCodec(format="png")
    msg = codec.encode(image)
    assert msg.format.endswith("; png compressed " + msg.format.split(";")[0])
    assert same(codec.decode(msg), image)
    assert same(codec.decode(wire_view(msg)), image)


def test_jpeg_round_trip_is_close() -> None:
    image = np.zeros((16, 16, 3), np.uint8)
    image[:, :8] = (255, 0, 0)  # blue in BGR
    codec = CompressedImageCodec(format="jpeg", quality=95)
    msg = codec.encode(image)
    assert msg.format == "bgr8; jpeg compressed bgr8"
    decoded = codecs.decode(msg)
    assert decoded.shape == image.shape and decoded.dtype == np.uint8
    assert np.abs(decoded.astype(int) - image).mean() < 8
    # BGR order survives: the left half is still blue, away from the chroma edge.
    assert decoded[:, :4, 0].min() > 200 and decoded[:, :4, 2].max() < 40
    low = CompressedImageCodec(quality=10).encode(
        np.random.default_rng(0).integers(0, 255, (64, 64, 3), dtype=np.uint8)
    )
    high = CompressedImageCodec(quality=100).encode(
        np.random.default_rng(0).integers(0, 255, (64, 64, 3), dtype=np.uint8)
    )
    assert len(low.data) < len(high.data)


def test_corrupt_and_empty_payloads_get_a_decode_error() -> None:
    for payload, what in [
        (b"\xff\xd8\xff\xe0\x00\x10JFIF", "jpeg"),
        (b"", "png"),
        (b"\x89PNG\r\n", "png"),
    ]:
        msg = CompressedImage(format=what)
        msg.data.frombytes(payload)
        with pytest.raises(DecodeError) as error:
            decode_compressed_image(msg)
        assert str(error.value) == (
            f"CompressedImage.data: cannot decode {len(payload)} bytes as {what}"
        )


def test_compressed_depth_16_and_32_bit() -> None:
    depth = np.array([[0, 1000], [2000, 65535]], np.uint16)
    payload = cv2.imencode(".png", depth)[1].tobytes()
    msg = CompressedImage(format="16UC1; compressedDepth png")
    msg.data.frombytes(struct.pack("<iff", 0, 0.0, 0.0) + payload)
    assert same(decode_compressed_image(msg), depth)
    # 32FC1: depth = quant_a / (value - quant_b); 0 means no reading.
    quant_a, quant_b = 100.0, 1.0
    inverse = np.array([[0, 101], [51, 11]], np.uint16)
    msg = CompressedImage(format="32FC1; compressedDepth png")
    msg.data.frombytes(
        struct.pack("<iff", 0, quant_a, quant_b) + cv2.imencode(".png", inverse)[1].tobytes()
    )
    decoded = decode_compressed_image(msg)
    assert decoded.dtype == np.float32 and np.isnan(decoded[0, 0])
    assert decoded[0, 1] == 1.0 and decoded[1, 0] == 2.0 and decoded[1, 1] == 10.0
    msg = CompressedImage(format="16UC1; compressedDepth png")
    msg.data.frombytes(b"\x00" * 5)
    with pytest.raises(DecodeError) as error:
        decode_compressed_image(msg)
    assert str(error.value) == (
        "CompressedImage.data: compressedDepth needs a 12-byte header, got 5 bytes"
    )


@pytest.mark.parametrize("encoding", ["16UC1", "32FC1"])
@pytest.mark.parametrize(
    ("pixels", "got"),
    [
        (np.full((4, 5, 3), 200, np.uint8), "uint8 with 3 channels"),
        (np.full((4, 5), 200, np.uint8), "uint8 with 1 channel"),
        (np.full((4, 5, 3), 200, np.uint16), "uint16 with 3 channels"),
    ],
)
def test_compressed_depth_of_another_png_is_a_decode_error(
    encoding: str, pixels: np.ndarray, got: str
) -> None:
    # It decoded to a (4, 5, 3) uint8 or float32 "depth" image.
    msg = CompressedImage(format=f"{encoding}; compressedDepth png")
    msg.data.frombytes(
        struct.pack("<iff", 0, 1000.0, 0.0) + cv2.imencode(".png", pixels)[1].tobytes()
    )
    with pytest.raises(DecodeError) as error:
        decode_compressed_image(msg)
    assert str(error.value) == (
        f"CompressedImage.data: compressedDepth expects a 16-bit 1-channel png, got {got}"
    )


def test_encode_errors() -> None:
    with pytest.raises(EncodeError) as error:
        CompressedImageCodec(format="jpeg").encode(np.zeros((2, 2), np.uint16))
    assert str(error.value) == (
        "CompressedImage: jpeg expects uint8 (H, W) or (H, W, 3), got uint16 of shape (2, 2)"
    )
    with pytest.raises(EncodeError) as not_array:
        CompressedImageCodec().encode([[1]])
    assert str(not_array.value) == "CompressedImage: expected numpy.ndarray, got list"
    with pytest.raises(EncodeError) as bad_format:
        CompressedImageCodec(format="webp")
    assert str(bad_format.value) == (
        "CompressedImageCodec: format must be jpeg, png or compressedDepth, got 'webp'"
    )
    assert CompressedImageCodec().lossless is False
    for shape in [(0, 4, 3), (4, 0)]:  # OpenCV's own error would name no field
        with pytest.raises(EncodeError) as empty:
            CompressedImageCodec().encode(np.zeros(shape, np.uint8))
        assert str(empty.value) == f"CompressedImage: cannot compress an empty image (shape {shape})"
    with pytest.raises(EncodeError) as too_wide:
        CompressedImageCodec().encode(np.zeros((1, 70_000), np.uint8))  # JPEG's limit is 65,500
    assert str(too_wide.value).startswith("CompressedImage: OpenCV could not encode (1, 70000) as jpeg")


def test_big_endian_16_bit_png() -> None:
    image = np.array([[1, 258]], ">u2")
    decoded = CompressedImageCodec(format="png").decode(
        CompressedImageCodec(format="png").encode(image)
    )
    assert decoded.tolist() == [[1, 258]]
