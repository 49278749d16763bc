"""cv_bridge's ``imgmsg_to_cv2``/``cv2_to_imgmsg`` and ``ImageCodec`` decoding to an encoding."""

from __future__ import annotations

import array

import cv2
import numpy as np
import pytest
from sensor_msgs.msg import Image
from std_msgs.msg import Header

from pyconnect import codecs
from pyconnect.codecs import CvBridgeError, cv2_to_imgmsg, imgmsg_to_cv2
from pyconnect.codecs.image import ImageCodec
from pyconnect.errors import DecodeError

RNG = np.random.default_rng(11)


def _message(pixels: np.ndarray, encoding: str, *, step: int | None = None) -> Image:
    rows = pixels.reshape(pixels.shape[0], -1).view(np.uint8)
    row_bytes = rows.shape[1]
    step = row_bytes if step is None else step
    padded = np.zeros((pixels.shape[0], step), np.uint8)
    padded[:, :row_bytes] = rows
    msg = Image(height=pixels.shape[0], width=pixels.shape[1], encoding=encoding, step=step)
    msg.data = array.array("B", padded.tobytes())
    return msg


def test_passthrough_keeps_the_encoding_and_is_writable() -> None:
    bgr = RNG.integers(0, 256, (4, 5, 3), dtype=np.uint8)
    image = imgmsg_to_cv2(_message(bgr, "bgr8", step=16))
    assert np.array_equal(image, bgr)
    cv2.rectangle(image, (0, 0), (2, 2), (255, 0, 0), 1)  # writable, as cv_bridge's result
    assert image[0, 0].tolist() == [255, 0, 0]


def test_desired_encoding_converts() -> None:
    bgr = RNG.integers(0, 256, (4, 5, 3), dtype=np.uint8)
    msg = _message(bgr, "bgr8")
    assert np.array_equal(imgmsg_to_cv2(msg, "rgb8"), bgr[:, :, ::-1])
    assert np.array_equal(
        imgmsg_to_cv2(msg, desired_encoding="mono8"), cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
    )


def test_big_endian_comes_back_native_and_writable() -> None:
    depth = np.array([[1, 2], [3, 65535]], ">u2")
    msg = _message(depth, "mono16")
    msg.is_bigendian = 1
    image = imgmsg_to_cv2(msg)
    assert image.dtype == np.dtype("=u2") and image.tolist() == [[1, 2], [3, 65535]]
    image[0, 0] = 7


def test_read_only_buffers_are_copied() -> None:
    codec = codecs.wire.wire_codec("sensor_msgs/msg/Image")
    cdr = codecs.wire.encode(RNG.integers(0, 256, (3, 4), dtype=np.uint8), "sensor_msgs/Image")
    view = codec.decode_view(cdr)
    assert not codecs.wire.decode(cdr, "sensor_msgs/Image").flags.writeable
    image = imgmsg_to_cv2(view)
    image[0, 0] = 1
    assert image.flags.writeable


def test_cv2_to_imgmsg_passthrough_uses_the_opencv_type() -> None:
    pixels = RNG.integers(0, 256, (3, 4, 3), dtype=np.uint8)
    msg = cv2_to_imgmsg(pixels)
    assert (msg.encoding, msg.height, msg.width, msg.step) == ("8UC3", 3, 4, 12)
    assert bytes(msg.data) == pixels.tobytes()
    floats = np.zeros((2, 2), np.float32)
    assert cv2_to_imgmsg(floats).encoding == "32FC1"


def test_cv2_to_imgmsg_with_an_encoding_and_a_header() -> None:
    header = Header(frame_id="camera")
    msg = cv2_to_imgmsg(np.zeros((2, 3, 3), np.uint8), encoding="rgb8", header=header)
    assert (msg.encoding, msg.header.frame_id) == ("rgb8", "camera")
    assert np.array_equal(imgmsg_to_cv2(msg), np.zeros((2, 3, 3), np.uint8))


def test_cv_bridge_errors() -> None:
    with pytest.raises(CvBridgeError) as error:
        cv2_to_imgmsg(np.zeros((2, 2), np.uint8), encoding="bgr8")
    assert str(error.value) == "encoding specified as bgr8, but image has incompatible type 8UC1"
    assert isinstance(error.value, TypeError)
    with pytest.raises(TypeError) as not_array:
        cv2_to_imgmsg([[1, 2]])
    assert str(not_array.value) == (
        "Your input type is not a numpy array of shape (H, W) or (H, W, C), got list"
    )
    with pytest.raises(CvBridgeError) as unknown:
        imgmsg_to_cv2(_message(np.zeros((1, 1), np.uint8), "mono8"), "nope8")
    assert str(unknown.value).startswith("convert: unknown image encoding 'nope8' (known: ")


def test_image_codec_decodes_to_its_encoding() -> None:
    rgb = RNG.integers(0, 256, (4, 5, 3), dtype=np.uint8)
    msg = _message(rgb, "rgb8")
    assert np.array_equal(ImageCodec(encoding="bgr8").decode(msg), rgb[:, :, ::-1])
    same = ImageCodec(encoding="rgb8").decode(msg)
    assert np.shares_memory(same, np.frombuffer(msg.data, np.uint8))  # no work, no copy
    with pytest.raises(DecodeError) as error:
        ImageCodec(encoding="bgr8").decode(_message(np.zeros((1, 1), np.float32), "32FC1"))
    assert str(error.value) == (
        "Image.encoding: convert: [32FC1] is not a color format. but [bgr8] is. "
        "The conversion does not make sense"
    )


def test_image_codec_copy_gives_an_array_of_its_own() -> None:
    cdr = codecs.wire.encode(np.arange(12, dtype=np.uint8).reshape(3, 4), "sensor_msgs/Image")
    view = codecs.wire.wire_codec("sensor_msgs/msg/Image").decode_view(cdr)
    image = ImageCodec(copy=True).decode(view)
    image[0, 0] = 99
    assert image.flags.owndata and ImageCodec().decode(view)[0, 0] == 0
    assert repr(ImageCodec(copy=True)) == "ImageCodec(encoding=None, copy=True)"


def test_generic_depth_changes_saturate_and_colour_targets_are_refused() -> None:
    depth = _message(np.array([[0.6, 300.0, -1.0, 1.5]], np.float32), "32FC1")
    assert imgmsg_to_cv2(depth, "8UC1").tolist() == [[1, 255, 0, 2]]
    with pytest.raises(CvBridgeError) as error:
        imgmsg_to_cv2(depth, "mono8")
    assert str(error.value) == (
        "convert: [32FC1] is not a color format. but [mono8] is. The conversion does not make sense"
    )


def _raw(encoding: str, height: int, width: int, step: int, data: bytes) -> Image:
    msg = Image(height=height, width=width, encoding=encoding, step=step)
    msg.data = array.array("B", data)
    return msg


def test_images_opencv_refuses_raise_the_bridges_errors() -> None:
    cases = [
        (_raw("yuv422", 2, 3, 6, bytes(12)), "bgr8",
         "convert: OpenCV cannot convert [yuv422] to [bgr8] for an array of shape (2, 3, 2) "
         "(yuv422 needs an even width)"),
        (_raw("nv21", 3, 3, 3, bytes(12)), "bgr8",
         "convert: OpenCV cannot convert [nv21] to [bgr8] for an array of shape (4, 3) "
         "(nv21 needs an even width and height)"),
    ]  # fmt: skip
    for msg, target, message in cases:
        with pytest.raises(CvBridgeError) as error:
            imgmsg_to_cv2(msg, target)
        assert str(error.value) == message
        with pytest.raises(DecodeError) as decode_error:
            ImageCodec(encoding=target).decode(msg)
        assert str(decode_error.value) == f"Image.encoding: {message}"


def test_empty_images_convert_without_opencv() -> None:
    empty_rgb = _raw("rgb8", 0, 4, 12, b"")
    assert imgmsg_to_cv2(empty_rgb, "bgr8").shape == (0, 4, 3)
    assert ImageCodec(encoding="bgr8").decode(empty_rgb).shape == (0, 4, 3)
    empty_bgr = _raw("bgr8", 0, 0, 0, b"")
    assert imgmsg_to_cv2(empty_bgr, "mono8").shape == (0, 0)
    assert ImageCodec(encoding="mono8").decode(empty_bgr).dtype == np.uint8


def test_generic_encodings_of_any_channel_count_and_bare_depths() -> None:
    five = RNG.integers(0, 256, (2, 3, 5), dtype=np.uint8)
    msg = cv2_to_imgmsg(five)
    assert (msg.encoding, msg.step) == ("8UC5", 15)
    assert np.array_equal(imgmsg_to_cv2(msg), five)
    depth = np.array([[1.5, -2.0]], np.float32)
    bare = _message(depth, "32F")
    assert np.array_equal(imgmsg_to_cv2(bare), depth)
    assert imgmsg_to_cv2(bare, "32FC1").dtype == np.float32
    assert cv2_to_imgmsg(depth, encoding="32F").encoding == "32F"
    wide = np.zeros((1, 1, 512), np.uint8)
    assert cv2_to_imgmsg(wide).encoding == "8UC512"
    with pytest.raises(CvBridgeError) as error:
        cv2_to_imgmsg(np.zeros((1, 1, 513), np.uint8))
    assert str(error.value) == "cv2_to_imgmsg: no OpenCV type for uint8 x 513"
