"""``convert``: cv_bridge-style encoding conversion with OpenCV."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from pyconnect.codecs.image_convert import ConversionError, convert

RNG = np.random.default_rng(7)


def test_rgb_bgr_and_alpha() -> None:
    bgr = RNG.integers(0, 256, (4, 6, 3), dtype=np.uint8)
    rgb = convert(bgr, "rgb8", source_encoding="bgr8")
    assert np.array_equal(rgb, bgr[:, :, ::-1])
    assert np.array_equal(convert(rgb, "bgr8", source_encoding="rgb8"), bgr)
    rgba = convert(bgr, "rgba8", source_encoding="bgr8")
    assert rgba.shape == (4, 6, 4) and np.all(rgba[:, :, 3] == 255)
    mono = convert(bgr, "mono8", source_encoding="bgr8")
    assert np.array_equal(mono, cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY))
    assert convert(bgr, "passthrough", source_encoding="bgr8") is bgr


def test_depth_scaling() -> None:
    mono16 = np.array([[0, 257, 65535, 32768]], np.uint16)
    assert convert(mono16, "mono8", source_encoding="mono16").tolist() == [[0, 1, 255, 128]]
    assert convert(
        np.array([[0, 1, 255]], np.uint8), "mono16", source_encoding="mono8"
    ).tolist() == [[0, 257, 65535]]
    big = mono16.astype(">u2")
    assert convert(big, "mono8", source_encoding="mono16").tolist() == [[0, 1, 255, 128]]
    rgb16 = convert(np.zeros((1, 1, 3), np.uint8) + 1, "bgr16", source_encoding="rgb8")
    assert rgb16.dtype == np.uint16 and rgb16.tolist() == [[[257, 257, 257]]]


@pytest.mark.parametrize(
    ("encoding", "code"),
    [
        ("bayer_rggb8", cv2.COLOR_BayerBG2BGR),
        ("bayer_bggr8", cv2.COLOR_BayerRG2BGR),
        ("bayer_gbrg8", cv2.COLOR_BayerGR2BGR),
        ("bayer_grbg8", cv2.COLOR_BayerGB2BGR),
    ],
)
def test_bayer_to_bgr(encoding: str, code: int) -> None:
    raw = RNG.integers(0, 256, (6, 8), dtype=np.uint8)
    assert np.array_equal(convert(raw, "bgr8", source_encoding=encoding), cv2.cvtColor(raw, code))


def test_bayer16_yuv_and_nv() -> None:
    raw16 = RNG.integers(0, 65536, (6, 8), dtype=np.uint16)
    out = convert(raw16, "bgr8", source_encoding="bayer_rggb16")
    expected = cv2.cvtColor(raw16, cv2.COLOR_BayerBG2BGR)
    assert np.array_equal(out, np.rint(expected * (255.0 / 65535.0)).astype(np.uint8))
    uyvy = RNG.integers(0, 256, (4, 6, 2), dtype=np.uint8)
    assert np.array_equal(
        convert(uyvy, "bgr8", source_encoding="yuv422"), cv2.cvtColor(uyvy, cv2.COLOR_YUV2BGR_UYVY)
    )
    assert np.array_equal(
        convert(uyvy, "rgb8", source_encoding="yuv422_yuy2"),
        cv2.cvtColor(uyvy, cv2.COLOR_YUV2RGB_YUY2),
    )
    nv21 = RNG.integers(0, 256, (6, 4), dtype=np.uint8)
    assert np.array_equal(
        convert(nv21, "bgr8", source_encoding="nv21"), cv2.cvtColor(nv21, cv2.COLOR_YUV2BGR_NV21)
    )
    # nv24: a grey Y plane with neutral chroma is grey.
    nv24 = np.full((6, 4), 128, np.uint8)
    nv24[:2] = 100
    out = convert(nv24, "bgr8", source_encoding="nv24")
    assert out.shape == (2, 4, 3) and np.all(np.abs(out.astype(int) - 100) <= 1)


def test_generic_and_errors() -> None:
    depth = np.array([[1.5, 2.5]], np.float32)
    assert convert(depth, "64FC1", source_encoding="32FC1").dtype == np.float64
    with pytest.raises(ConversionError) as error:
        convert(depth, "bgr8", source_encoding="32FC1")
    assert str(error.value) == (
        "convert: cannot convert '32FC1' (1 channels) to 'bgr8' (3 channels)"
    )
    with pytest.raises(ConversionError) as unknown:
        convert(depth, "hsv", source_encoding="32FC1")
    assert str(unknown.value).startswith("convert: unknown image encoding 'hsv'")
    with pytest.raises(ConversionError) as target:
        convert(np.zeros((2, 2), np.uint8), "bayer_rggb8", source_encoding="mono8")
    assert str(target.value).startswith("convert: cannot convert to 'bayer_rggb8'")
