"""Image decoding agrees with rosbags-image on every encoding both support."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from pyconnect.codecs.image import decode_image
from pyconnect.codecs.image_encodings import ALL_ENCODINGS, pixel_format
from tests.codecs.natural.helpers import EXAMPLES

rosbags_image = pytest.importorskip("rosbags.image")
typesys = pytest.importorskip("rosbags.typesys")
TYPESTORE = typesys.get_typestore(typesys.Stores.ROS2_JAZZY)
RosbagsImage = TYPESTORE.types["sensor_msgs/msg/Image"]
RosbagsHeader = TYPESTORE.types["std_msgs/msg/Header"]
RosbagsTime = TYPESTORE.types["builtin_interfaces/msg/Time"]


def rosbags_supports(encoding: str) -> bool:
    try:
        rosbags_image.image.to_cvtype(encoding)
    except rosbags_image.ImageFormatError:
        return False
    return True


# nv12/nv21 differ by convention (see pyconnect.codecs.image_encodings): rosbags-image reads
# `height` rows, we read the whole semi-planar buffer (height * 3/2 rows).
COMMON = [e for e in ALL_ENCODINGS if rosbags_supports(e) and e not in ("nv12", "nv21")]


def test_the_common_encodings_cover_the_named_and_generic_ones() -> None:
    assert {"mono8", "rgb16", "bayer_grbg16", "yuv422", "yuv422_yuy2", "64FC4"} <= set(COMMON)
    assert len(COMMON) >= 45


def rosbags_message(encoding: str, height: int, width: int, data: bytes, big: bool) -> Any:
    fmt = pixel_format(encoding)
    return RosbagsImage(
        header=RosbagsHeader(stamp=RosbagsTime(sec=0, nanosec=0), frame_id=""),
        height=height,
        width=width,
        encoding=encoding,
        is_bigendian=int(big),
        step=width * fmt.pixel_bytes,
        data=np.frombuffer(data, np.uint8),
    )


@EXAMPLES
@given(
    encoding=st.sampled_from(COMMON),
    height=st.integers(1, 4),
    width=st.integers(1, 5),
    big=st.booleans(),
    seed=st.integers(0, 2**32 - 1),
)
def test_decode_agrees_with_rosbags_image(
    encoding: str, height: int, width: int, big: bool, seed: int
) -> None:
    fmt = pixel_format(encoding)
    size = height * width * fmt.pixel_bytes
    data = np.random.default_rng(seed).integers(0, 256, size, dtype=np.uint8).tobytes()
    msg = rosbags_message(encoding, height, width, data, big and fmt.dtype.itemsize > 1)
    ours = decode_image(msg)  # the rosbags message itself: decode reads attributes only
    theirs = rosbags_image.message_to_cvimage(msg)
    assert ours.shape == theirs.shape
    assert np.array_equal(ours, theirs, equal_nan=fmt.dtype.kind == "f")
    assert ours.astype(ours.dtype.newbyteorder("=")).tobytes() == theirs.tobytes()


@pytest.mark.parametrize("encoding", COMMON)
def test_each_common_encoding_once(encoding: str) -> None:
    fmt = pixel_format(encoding)
    data = bytes(range(256))[: 2 * 3 * fmt.pixel_bytes]
    msg = rosbags_message(encoding, 2, 3, data, False)
    theirs = rosbags_image.message_to_cvimage(msg)
    assert np.array_equal(decode_image(msg), theirs, equal_nan=True)
