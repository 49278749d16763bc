"""Image ↔ ndarray: zero-copy decode, padding, byte order, inference, errors, round trips."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from pyconnect import codecs
from pyconnect.codecs import image as image_module
from pyconnect.codecs.image import ImageCodec, decode_image, encode_image, image_fields
from pyconnect.codecs.image_encodings import ALL_ENCODINGS, NAMED_ENCODINGS, pixel_format
from pyconnect.errors import DecodeError, EncodeError
from tests.codecs.natural.helpers import EXAMPLES, same, wire_view

Image = pytest.importorskip("sensor_msgs.msg").Image


def make_image(
    encoding: str,
    height: int,
    width: int,
    *,
    step: int | None = None,
    data: bytes = b"",
    big_endian: bool = False,
) -> Any:
    fmt = pixel_format(encoding)
    row = width * fmt.pixel_bytes
    msg = Image(
        height=height,
        width=width,
        encoding=encoding,
        is_bigendian=int(big_endian),
        step=row if step is None else step,
    )
    msg.data.frombytes(data)
    return msg


def buffer_of(msg: Any) -> np.ndarray:
    return np.frombuffer(msg.data, np.uint8)


def test_decode_is_a_zero_copy_view_with_the_natural_shape() -> None:
    pixels = np.arange(2 * 3 * 3, dtype=np.uint8).reshape(2, 3, 3)
    msg = encode_image(pixels)
    decoded = decode_image(msg)
    assert decoded.shape == (2, 3, 3)
    assert np.shares_memory(decoded, buffer_of(msg))
    assert np.array_equal(decoded, pixels)
    mono = decode_image(encode_image(pixels[:, :, 0].copy()))
    assert mono.shape == (2, 3)


def test_padded_rows_are_skipped_without_a_copy() -> None:
    rows = [
        bytes([1, 2, 3, 4, 5, 6, 7, 8, 9]) + b"\xee\xee\xee",
        bytes(range(10, 19)) + b"\xee" * 3,
    ]
    msg = make_image("rgb8", 2, 3, step=12, data=b"".join(rows))
    decoded = decode_image(msg)
    assert decoded.tolist() == [
        [[1, 2, 3], [4, 5, 6], [7, 8, 9]],
        [[10, 11, 12], [13, 14, 15], [16, 17, 18]],
    ]
    assert np.shares_memory(decoded, buffer_of(msg))
    # Re-encoding packs the rows.
    again = encode_image(decoded, encoding="rgb8")
    assert again.step == 9 and bytes(again.data) == bytes(range(1, 19))


def test_big_endian_16_bit_decodes_to_the_right_values_zero_copy() -> None:
    msg = make_image("mono16", 1, 2, data=b"\x01\x02\xff\x00", big_endian=True)
    decoded = decode_image(msg)
    assert decoded.tolist() == [[0x0102, 0xFF00]]
    assert decoded.dtype == np.dtype(">u2")
    assert np.shares_memory(decoded, buffer_of(msg))
    little = decode_image(make_image("mono16", 1, 2, data=b"\x01\x02\xff\x00"))
    assert little.tolist() == [[0x0201, 0x00FF]]


def test_big_endian_arrays_encode_as_is_with_the_flag() -> None:
    pixels = np.array([[1, 258]], dtype=">u2")
    msg = encode_image(pixels)
    assert (msg.encoding, msg.is_bigendian, bytes(msg.data)) == ("mono16", 1, b"\x00\x01\x01\x02")
    assert decode_image(msg).tolist() == [[1, 258]]
    native = encode_image(pixels.astype("<u2"))
    assert native.is_bigendian == 0


@pytest.mark.parametrize(
    ("dtype", "shape", "encoding"),
    [
        ("uint8", (2, 3), "mono8"),
        ("uint8", (2, 3, 3), "bgr8"),
        ("uint8", (2, 3, 4), "bgra8"),
        ("uint8", (2, 3, 2), "8UC2"),
        ("uint16", (2, 3), "mono16"),
        ("uint16", (2, 3, 3), "16UC3"),
        ("float32", (2, 3), "32FC1"),
        ("float32", (2, 3, 2), "32FC2"),
        ("float64", (2, 3), "64FC1"),
        ("int8", (2, 3), "8SC1"),
        ("int16", (2, 3, 4), "16SC4"),
        ("int32", (2, 3), "32SC1"),
    ],
)
def test_encoding_is_inferred_from_dtype_and_shape(
    dtype: str, shape: tuple[int, ...], encoding: str
) -> None:
    msg = encode_image(np.zeros(shape, dtype))
    assert msg.encoding == encoding
    assert msg.step == shape[1] * np.dtype(dtype).itemsize * (shape[2] if len(shape) == 3 else 1)


def test_explicit_encoding_through_a_registered_codec() -> None:
    registry = codecs.Registry()
    registry.register(Image, ImageCodec(encoding="rgb8"), override=True)
    msg = registry.encode(np.zeros((2, 2, 3), np.uint8), Image)
    assert msg.encoding == "rgb8"


def test_non_contiguous_input_encodes_correctly() -> None:
    base = np.arange(4 * 6 * 3, dtype=np.uint8).reshape(4, 6, 3)
    for view in (base[:, ::2], base[1:3, 2:5], base.transpose(1, 0, 2), base[::-1]):
        assert not view.flags.c_contiguous or view is base
        assert np.array_equal(decode_image(encode_image(view)), view)
    assert np.array_equal(decode_image(encode_image(base[:, :, 0])), base[:, :, 0])


def test_decode_works_on_wire_views_and_read_only_buffers() -> None:
    pixels = np.arange(12, dtype=np.uint16).reshape(2, 6)
    view = wire_view(encode_image(pixels))
    assert not view.data.flags.writeable
    decoded = decode_image(view)
    assert np.array_equal(decoded, pixels) and np.shares_memory(decoded, view.data)
    as_bytes = wire_view(encode_image(pixels))
    as_bytes.data = bytes(as_bytes.data)
    assert np.array_equal(decode_image(as_bytes), pixels)


def test_image_fields_are_the_dict_shape_of_the_message() -> None:
    pixels = np.arange(6, dtype=np.uint8).reshape(2, 3)
    fields = image_fields(pixels)
    assert {k: v for k, v in fields.items() if k != "data"} == {
        "height": 2,
        "width": 3,
        "encoding": "mono8",
        "is_bigendian": 0,
        "step": 3,
    }
    assert bytes(fields["data"]) == bytes(range(6))
    assert ImageCodec(encoding="mono8").to_fields(pixels)["encoding"] == "mono8"


# -- errors ---------------------------------------------------------------------------------
def test_data_shorter_than_step_times_height() -> None:
    msg = make_image("rgb8", 480, 640, data=bytes(100))
    with pytest.raises(DecodeError) as error:
        decode_image(msg)
    assert str(error.value) == (
        "Image.data: expected at least 921600 bytes (step 1920 × height 480), got 100"  # noqa: RUF001
    )


def test_step_shorter_than_a_row() -> None:
    msg = make_image("rgb8", 1, 4, step=10, data=bytes(12))
    with pytest.raises(DecodeError) as error:
        decode_image(msg)
    assert str(error.value) == (
        "Image.step: expected at least 12 (width 4 × 3 bytes per pixel of rgb8), got 10"  # noqa: RUF001
    )


def test_unknown_encoding_is_named() -> None:
    msg = Image(height=1, width=1, encoding="hsv8", step=3)
    with pytest.raises(DecodeError) as error:
        decode_image(msg)
    assert str(error.value) == (
        "Image.encoding: unknown image encoding 'hsv8' (known: "
        + ", ".join(NAMED_ENCODINGS)
        + " and {8U,8S,16U,16S,32S,32F,64F} alone or with C{1..512})"
    )
    with pytest.raises(EncodeError) as encode_error:
        ImageCodec(encoding="hsv8")
    assert str(encode_error.value).startswith("ImageCodec: unknown image encoding 'hsv8'")


def test_layout_cache_stays_bounded_under_many_encodings() -> None:
    # Encodings come from the data; every generic one in both byte orders would be 7 x 512 x
    # 2 layouts kept for ever.
    for depth in ("8U", "8S", "16U", "16S", "32S", "32F", "64F"):
        for channels in range(1, 513, 3):
            for big_endian in (0, 1):
                encoding = f"{depth}C{channels}"
                fmt = pixel_format(encoding)
                msg = Image(height=1, width=1, encoding=encoding, step=fmt.pixel_bytes)
                msg.is_bigendian = big_endian
                msg.data.frombytes(bytes(fmt.pixel_bytes))
                assert decode_image(msg).size == channels
    assert len(image_module._LAYOUTS) <= 512  # of the 2394 decoded


def test_wrong_dtype_for_an_explicit_encoding() -> None:
    with pytest.raises(EncodeError) as error:
        ImageCodec(encoding="rgb8").encode(np.zeros((2, 2, 3), np.float32))
    assert str(error.value) == "Image.data: encoding 'rgb8' expects uint8, got float32"


def test_wrong_shape_for_an_explicit_encoding() -> None:
    with pytest.raises(EncodeError) as error:
        ImageCodec(encoding="rgb8").encode(np.zeros((2, 2), np.uint8))
    assert str(error.value) == "Image.data: encoding 'rgb8' expects shape (H, W, 3), got (2, 2)"


def test_not_an_array() -> None:
    with pytest.raises(EncodeError) as error:
        encode_image({"data": [1, 2]})
    assert str(error.value) == "Image: expected numpy.ndarray, got dict"
    with pytest.raises(EncodeError) as shape_error:
        encode_image(np.zeros(3, np.uint8))
    assert str(shape_error.value) == (
        "Image: expected an ndarray of shape (H, W) or (H, W, C), got shape (3,)"
    )


def test_dtype_without_an_encoding() -> None:
    with pytest.raises(EncodeError) as error:
        encode_image(np.zeros((2, 2), np.uint32))
    assert str(error.value) == (
        "Image: cannot infer an encoding for uint32 with 1 channels (dtypes: uint8, int8, "
        "uint16, int16, int32, float32, float64; 1-512 channels); pass ImageCodec(encoding=...)"
    )


def test_semi_planar_row_count() -> None:
    with pytest.raises(EncodeError) as error:
        ImageCodec(encoding="nv21").encode(np.zeros((4, 4), np.uint8))
    assert str(error.value) == (
        "Image.data: encoding 'nv21' expects a row count that is a multiple of 3 "
        "(image height × 3/2), got 4"  # noqa: RUF001
    )
    msg = ImageCodec(encoding="nv21").encode(np.zeros((6, 4), np.uint8))
    assert (msg.height, msg.width, msg.step, len(msg.data)) == (4, 4, 4, 24)
    assert decode_image(msg).shape == (6, 4)
    nv24 = ImageCodec(encoding="nv24").encode(np.zeros((6, 4), np.uint8))
    assert (nv24.height, decode_image(nv24).shape) == (2, (6, 4))


# -- round trips ----------------------------------------------------------------------------
@st.composite
def image_messages(draw: st.DrawFn) -> Any:
    encoding = draw(st.sampled_from(ALL_ENCODINGS))
    fmt = pixel_format(encoding)
    height = draw(st.integers(0, 5))
    if fmt.rows_per_row != 1:
        height -= height % 2
    width = draw(st.integers(0, 7))
    padding = draw(st.sampled_from([0, 0, 1, 3, 8]))
    step = width * fmt.pixel_bytes + padding
    rows = int(height * fmt.rows_per_row)
    data = draw(st.binary(min_size=step * rows, max_size=step * rows))
    big_endian = draw(st.booleans()) if fmt.dtype.itemsize > 1 else False
    return make_image(encoding, height, width, step=step, data=data, big_endian=big_endian)


@EXAMPLES
@given(image_messages())
def test_every_encoding_round_trips_from_a_message(msg: Any) -> None:
    decoded = decode_image(msg)
    codec = ImageCodec(encoding=msg.encoding)
    again = codec.encode(decoded)
    assert (again.height, again.width, again.encoding) == (msg.height, msg.width, msg.encoding)
    assert again.is_bigendian == msg.is_bigendian
    assert same(codec.decode(again), decoded)


@st.composite
def image_arrays(draw: st.DrawFn) -> tuple[str, np.ndarray]:
    encoding = draw(st.sampled_from(ALL_ENCODINGS))
    fmt = pixel_format(encoding)
    rows = draw(st.integers(0, 4))
    if fmt.rows_per_row != 1:
        rows *= 3
    width = draw(st.integers(0, 5))
    shape = (rows, width) if fmt.channels == 1 else (rows, width, fmt.channels)
    order = draw(st.sampled_from("<>")) if fmt.dtype.itemsize > 1 else "|"
    dtype = fmt.dtype.newbyteorder(order) if order != "|" else fmt.dtype
    raw = draw(
        st.binary(
            min_size=int(np.prod(shape)) * dtype.itemsize,
            max_size=int(np.prod(shape)) * dtype.itemsize,
        )
    )
    return encoding, np.frombuffer(raw, dtype).reshape(shape)


@EXAMPLES
@given(image_arrays())
def test_every_encoding_round_trips_from_an_array(case: tuple[str, np.ndarray]) -> None:
    encoding, pixels = case
    codec = ImageCodec(encoding=encoding)
    decoded = codec.decode(codec.encode(pixels))
    assert same(decoded, pixels)


def test_edge_sizes_round_trip() -> None:
    for shape in [(0, 0), (0, 5), (5, 0), (1, 1), (1, 1, 3), (3, 7, 3), (5, 1)]:
        pixels = np.arange(int(np.prod(shape)), dtype=np.uint8).reshape(shape)
        assert np.array_equal(decode_image(encode_image(pixels)), pixels)
        assert decode_image(encode_image(pixels)).shape == shape
    nan = np.array([[np.nan, -0.0, np.inf]], np.float32)
    assert decode_image(encode_image(nan)).tobytes() == nan.tobytes()


# Padded nv24 rows are not step apart (test_padded_nv24_reads_chroma_rows_of_twice_the_step).
@pytest.mark.parametrize("encoding", [e for e in ALL_ENCODINGS if e != "nv24"])
@pytest.mark.parametrize("big_endian", [False, True])
def test_each_encoding_with_padded_rows_and_both_byte_orders(
    encoding: str, big_endian: bool
) -> None:
    fmt = pixel_format(encoding)
    height, width = 2, 3
    rows = int(height * fmt.rows_per_row)
    step = width * fmt.pixel_bytes + 5  # padded, and odd
    data = bytes(i % 251 for i in range(step * rows))
    msg = make_image(encoding, height, width, step=step, data=data, big_endian=big_endian)
    decoded = decode_image(msg)
    assert decoded.shape[:2] == (rows, width)
    assert np.shares_memory(decoded, buffer_of(msg))
    # Each pixel row starts at row * step: compare with the bytes read directly.
    for row in range(rows):
        raw = data[row * step : row * step + width * fmt.pixel_bytes]
        order = ">" if big_endian and fmt.dtype.itemsize > 1 else "<"
        expected = np.frombuffer(raw, fmt.dtype.newbyteorder(order))
        assert decoded[row].reshape(-1).tobytes() == expected.tobytes()
    again = ImageCodec(encoding=encoding).encode(decoded)
    assert again.step == width * fmt.pixel_bytes
    assert same(decode_image(again), decoded)


def test_decoding_a_message_of_another_type_names_both_types() -> None:
    # lookup(Image).decode(Point()) raised "'Point' object has no attribute '_encoding'".
    from geometry_msgs.msg import Point

    with pytest.raises(DecodeError) as raised:
        codecs.lookup(Image).decode(Point())
    assert str(raised.value) == "expected sensor_msgs/msg/Image, got geometry_msgs/msg/Point"


def _nv24_planes(height: int, width: int, step: int) -> tuple[np.ndarray, np.ndarray, bytes]:
    """Random Y and interleaved CbCr planes, and V4L2's NV24 buffer of them for ``step``."""
    rng = np.random.default_rng(24)
    luma = rng.integers(0, 256, (height, width), dtype=np.uint8)
    chroma = rng.integers(0, 256, (height, 2 * width), dtype=np.uint8)
    luma_rows = np.zeros((height, step), np.uint8)
    luma_rows[:, :width] = luma
    chroma_rows = np.full((height, 2 * step), 0xEE, np.uint8)  # padding that must be skipped
    chroma_rows[:, : 2 * width] = chroma
    return luma, chroma, luma_rows.tobytes() + chroma_rows.tobytes()


def test_padded_nv24_reads_chroma_rows_of_twice_the_step() -> None:
    luma, chroma, data = _nv24_planes(3, 4, 7)
    expected = np.concatenate((luma, chroma.reshape(6, 4)))
    msg = make_image("nv24", 3, 4, step=7, data=data)
    assert np.array_equal(decode_image(msg), expected)
    by_hand = SimpleNamespace(
        encoding="nv24", is_bigendian=0, height=3, width=4, step=7, data=list(data)
    )
    assert np.array_equal(decode_image(by_hand), expected)
    packed = make_image("nv24", 3, 4, data=_nv24_planes(3, 4, 4)[2])
    assert np.array_equal(decode_image(packed), expected)


@pytest.mark.parametrize(
    ("encoding", "shape", "dtype"),
    [("32F", (2, 3), np.float32), ("16U", (2, 3), np.uint16), ("8UC5", (2, 3, 5), np.uint8),
     ("32FC6", (2, 3, 6), np.float32)],
)  # fmt: skip
def test_bare_depths_and_more_than_four_channels(
    encoding: str, shape: tuple[int, ...], dtype: type
) -> None:
    pixels = np.arange(np.prod(shape)).astype(dtype).reshape(shape)
    msg = make_image(encoding, 2, 3, data=pixels.tobytes())
    assert same(decode_image(msg), pixels)
    assert same(decode_image(ImageCodec(encoding=encoding).encode(pixels)), pixels)
    if len(shape) == 3:  # inferred: cv_bridge's name for the type
        assert encode_image(pixels).encoding == encoding
