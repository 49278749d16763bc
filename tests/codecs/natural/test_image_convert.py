"""``convert``: cv_bridge-style encoding conversion with OpenCV."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from pyconnect.codecs.image_convert import ConversionError, convert
from tests.codecs.natural.helpers import EXAMPLES

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
        convert(depth, "32FC3", source_encoding="32FC1")
    assert str(error.value) == (
        "convert: cannot convert '32FC1' (1 channels) to '32FC3' (3 channels)"
    )
    with pytest.raises(ConversionError) as colour:
        convert(np.zeros((2, 2, 3), np.uint8), "8UC1", source_encoding="bgr8")
    assert str(colour.value) == (
        "convert: cannot convert 'bgr8' (3 channels) to '8UC1' (1 channels)"
    )
    with pytest.raises(ConversionError) as unknown:
        convert(depth, "hsv", source_encoding="32FC1")
    assert str(unknown.value).startswith("convert: unknown image encoding 'hsv'")
    with pytest.raises(ConversionError) as target:
        convert(np.zeros((2, 2), np.uint8), "bayer_rggb8", source_encoding="mono8")
    assert str(target.value).startswith("convert: cannot convert to 'bayer_rggb8'")


# cv_bridge's convertTo: 16 <-> 8 bits scale (by bit depth, signed too), the rest do not; integer
# targets round half to even and saturate.
@pytest.mark.parametrize(
    ("source", "values", "target", "expected"),
    [
        ("32FC1", np.array([[0.6, 300.0, -1.0, 1.5]], np.float32), "8UC1", [[1, 255, 0, 2]]),
        ("16SC1", np.array([[-5, 300, 20000]], np.int16), "8UC1", [[0, 1, 78]]),
        ("32SC1", np.array([[-1, 70000]], np.int32), "16UC1", [[0, 65535]]),
        (
            "32FC1",
            np.array([[0.5, 2.5, -0.5, -1.5, 255.5]], np.float32),
            "8SC1",
            [[0, 2, 0, -2, 127]],
        ),
        ("64FC1", np.array([[-40000.0, 40000.0, 65535.5]]), "16UC1", [[0, 40000, 65535]]),
        ("8SC1", np.array([[-1, 1, 127]], np.int8), "16UC1", [[0, 257, 32639]]),
        ("8SC1", np.array([[-128, 127]], np.int8), "16SC1", [[-32768, 32639]]),
        ("16UC1", np.array([[0, 257, 65535]], np.uint16), "8SC1", [[0, 1, 127]]),
        ("32SC1", np.array([[-200, 200]], np.int32), "8SC1", [[-128, 127]]),
        ("mono16", np.array([[65535, 32768]], np.uint16), "8SC1", [[127, 127]]),
        ("bgr8", np.array([[[0, 1, 255]]], np.uint8), "16SC3", [[[0, 257, 32767]]]),
    ],
)
def test_depth_changes_round_and_saturate(
    source: str, values: np.ndarray, target: str, expected: list[object]
) -> None:
    assert convert(values, target, source_encoding=source).tolist() == expected


def test_float_nan_and_out_of_int32_saturate_as_opencv_on_x86() -> None:
    # cvRound gives INT32_MIN for NaN, inf and anything beyond int32; that then saturates.
    odd = np.array([[np.nan, np.inf, -np.inf, 3e9, 1e6]], np.float32)
    assert convert(odd, "8UC1", source_encoding="32FC1").tolist() == [[0, 0, 0, 0, 255]]
    assert convert(odd, "16SC1", source_encoding="32FC1").tolist() == [
        [-32768, -32768, -32768, -32768, 32767]
    ]
    assert convert(odd, "32SC1", source_encoding="32FC1").tolist() == [[-(2**31)] * 4 + [10**6]]
    assert np.array_equal(
        convert(odd, "64FC1", source_encoding="32FC1"), odd.astype(np.float64), equal_nan=True
    )
    signalling = np.array([[0x7F800001, 0xFFA00000]], np.uint32).view(np.float32)
    assert convert(signalling, "8SC1", source_encoding="32FC1").tolist() == [[-128, -128]]
    assert np.isnan(convert(signalling, "64FC1", source_encoding="32FC1")).all()
    wide = np.array([[0x7FF0000000000001]], np.uint64).view(np.float64)
    assert np.isnan(convert(wide, "32FC1", source_encoding="64FC1")).all()


@pytest.mark.parametrize(
    ("source", "target"),
    [("32FC1", "mono8"), ("32FC1", "bgr8"), ("8UC3", "bgr8"), ("8UC1", "mono8")],
)
def test_generic_to_a_colour_encoding_is_refused_as_cv_bridge_does(
    source: str, target: str
) -> None:
    channels = int(source[-1])
    dtype = np.float32 if source.startswith("32F") else np.uint8
    image = np.zeros((2, 2) if channels == 1 else (2, 2, channels), dtype)
    with pytest.raises(ConversionError) as error:
        convert(image, target, source_encoding=source)
    assert str(error.value) == (
        f"convert: [{source}] is not a color format. but [{target}] is. "
        "The conversion does not make sense"
    )


def test_same_depth_generic_conversion_is_no_work() -> None:
    mono = np.zeros((2, 3), np.uint8)
    assert convert(mono, "8UC1", source_encoding="mono8") is mono
    bgr = np.zeros((2, 3, 3), np.uint16)
    assert convert(bgr, "16UC3", source_encoding="bgr16") is bgr


_DEPTHS = {
    "8U": (np.uint8, cv2.CV_8U),
    "8S": (np.int8, cv2.CV_8S),
    "16U": (np.uint16, cv2.CV_16U),
    "16S": (np.int16, cv2.CV_16S),
    "32S": (np.int32, cv2.CV_32S),
    "32F": (np.float32, cv2.CV_32F),
    "64F": (np.float64, cv2.CV_64F),
}


def _opencv_convert_to(image: np.ndarray, target: str) -> np.ndarray:
    """What cv_bridge's ``image.convertTo(dst, type, scale)`` gives, from OpenCV itself."""
    dtype, cv_depth = _DEPTHS[target]
    bits = (image.dtype.itemsize, np.dtype(dtype).itemsize)
    if bits == (1, 2):
        wide = image.astype(np.int64) * 257
    elif bits == (2, 1):
        # x * 255/65535 is never a half, so rounding half up in integers is exact.
        wide = (image.astype(np.int64) * 510 + 65535) // 131070
    else:
        # add() ends with the same saturate_cast as convertTo.
        return cv2.add(image, np.zeros_like(image), dtype=cv_depth)
    bounds = np.iinfo(dtype)
    return np.clip(wide, bounds.min, bounds.max).astype(dtype)


@st.composite
def depth_changes(draw: st.DrawFn) -> tuple[str, str, np.ndarray]:
    source, target = draw(st.permutations(list(_DEPTHS)))[:2]
    channels = draw(st.integers(1, 4))
    shape = (draw(st.integers(1, 3)), draw(st.integers(1, 5)), channels)
    dtype = np.dtype(_DEPTHS[source][0])
    raw = draw(
        st.binary(
            min_size=int(np.prod(shape)) * dtype.itemsize,
            max_size=int(np.prod(shape)) * dtype.itemsize,
        )
    )
    image = np.frombuffer(raw, dtype).reshape(shape)
    return f"{source}C{channels}", f"{target}C{channels}", image if channels > 1 else image[..., 0]


@EXAMPLES
@given(depth_changes())
def test_generic_depth_changes_match_opencv(case: tuple[str, str, np.ndarray]) -> None:
    source, target, image = case
    out = convert(image, target, source_encoding=source)
    expected = _opencv_convert_to(image, target[: target.index("C")])
    assert out.dtype == expected.dtype
    assert np.array_equal(out, expected, equal_nan=out.dtype.kind == "f")


@pytest.mark.parametrize(
    ("source", "shape", "target", "code"),
    [
        # One cvtColor, as cv_bridge: through BGR first, the grey of a Bayer image differed.
        ("bayer_rggb8", (6, 8), "mono8", cv2.COLOR_BayerBG2GRAY),
        ("bayer_grbg8", (6, 8), "rgb8", cv2.COLOR_BayerGB2RGB),
        ("yuv422", (4, 6, 2), "mono8", cv2.COLOR_YUV2GRAY_UYVY),
        ("yuv422_yuy2", (4, 6, 2), "rgba8", cv2.COLOR_YUV2RGBA_YUY2),
        ("nv21", (6, 4), "mono8", cv2.COLOR_YUV2GRAY_NV21),
        ("nv12", (6, 4), "bgra8", cv2.COLOR_YUV2BGRA_NV12),
    ],
)
def test_each_pair_is_the_one_conversion_cv_bridge_makes(
    source: str, shape: tuple[int, ...], target: str, code: int
) -> None:
    raw = RNG.integers(0, 256, shape, dtype=np.uint8)
    assert np.array_equal(convert(raw, target, source_encoding=source), cv2.cvtColor(raw, code))


@pytest.mark.parametrize("target", ["rgba8", "bgra8"])
def test_bayer_to_four_channels_is_refused_as_cv_bridge_does(target: str) -> None:
    with pytest.raises(ConversionError) as caught:
        convert(np.zeros((4, 4), np.uint8), target, source_encoding="bayer_rggb8")
    assert str(caught.value) == f"convert: Unsupported conversion from [bayer_rggb8] to [{target}]"


def _yuv_planes(height: int, width: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Y, U (Cb) and V (Cr) planes of colours far from 0 and 255, so nothing clips."""
    bgr = RNG.integers(60, 200, (height, width, 3), dtype=np.uint8)
    yuv = cv2.cvtColor(bgr, cv2.COLOR_BGR2YUV)
    return yuv[..., 0], yuv[..., 1], yuv[..., 2]


def test_nv24_chroma_is_cb_first() -> None:
    # V4L2's NV24: the Y plane, then Cb Cr pairs (U first), as in nv12.
    y, u, v = _yuv_planes(4, 6)
    nv24 = np.concatenate((y, np.dstack((u, v)).reshape(8, 6)))
    expected = cv2.cvtColor(np.dstack((y, u, v)), cv2.COLOR_YUV2BGR)
    assert np.array_equal(convert(nv24, "bgr8", source_encoding="nv24"), expected)
    assert np.array_equal(
        convert(nv24, "rgb8", source_encoding="nv24"), cv2.cvtColor(expected, cv2.COLOR_BGR2RGB)
    )
    # nv12 (U first) and nv21 (V first) of the same colours agree, subsampled 2x2.
    uv = np.dstack((u[::2, ::2], v[::2, ::2])).reshape(2, 6)
    nv12 = np.concatenate((y, uv))
    nv21 = np.concatenate((y, uv.reshape(2, 3, 2)[..., ::-1].reshape(2, 6)))
    assert np.array_equal(
        convert(nv12, "bgr8", source_encoding="nv12"),
        convert(nv21, "bgr8", source_encoding="nv21"),
    )


@pytest.mark.parametrize(
    ("source", "image", "target", "message"),
    [
        ("yuv422", np.zeros((2, 3, 2), np.uint8), "bgr8",
         "convert: OpenCV cannot convert [yuv422] to [bgr8] for an array of shape (2, 3, 2) "
         "(yuv422 needs an even width)"),
        ("nv21", np.zeros((4, 3), np.uint8), "bgr8",
         "convert: OpenCV cannot convert [nv21] to [bgr8] for an array of shape (4, 3) "
         "(nv21 needs an even width and height)"),
        ("nv24", np.zeros((4, 3), np.uint8), "bgr8",
         "convert: [nv24] expects a 2-D array of 3 * height rows, got shape (4, 3)"),
    ],
)  # fmt: skip
def test_opencv_refusals_are_conversion_errors(
    source: str, image: np.ndarray, target: str, message: str
) -> None:
    with pytest.raises(ConversionError) as error:
        convert(image, target, source_encoding=source)
    assert str(error.value) == message


@pytest.mark.parametrize(
    ("source", "shape", "dtype", "target", "expected"),
    [
        ("rgb8", (0, 4, 3), np.uint8, "bgr8", (0, 4, 3)),
        ("bgr8", (0, 0, 3), np.uint8, "mono8", (0, 0)),
        ("mono8", (3, 0), np.uint8, "rgba8", (3, 0, 4)),
        ("rgb16", (0, 2, 3), np.uint16, "mono8", (0, 2)),
        ("bayer_rggb8", (0, 2), np.uint8, "bgr8", (0, 2, 3)),
        ("yuv422", (0, 2, 2), np.uint8, "rgb8", (0, 2, 3)),
        ("nv12", (0, 2), np.uint8, "bgra8", (0, 2, 4)),
        ("nv24", (0, 2), np.uint8, "mono8", (0, 2)),
    ],
)
def test_empty_images_convert_to_empty_arrays(
    source: str, shape: tuple[int, ...], dtype: type, target: str, expected: tuple[int, ...]
) -> None:
    out = convert(np.zeros(shape, dtype), target, source_encoding=source)
    assert out.shape == expected
    assert out.dtype == (np.uint16 if target.endswith("16") else np.uint8)
