"""Formats seen on real robots: compressedDepth both ways, 16-bit PNG, odd PointCloud2 layouts."""

from __future__ import annotations

import struct
from typing import Any

import cv2
import numpy as np
import pytest
from sensor_msgs.msg import CompressedImage, PointCloud2, PointField

from pyconnect.codecs import wire
from pyconnect.codecs.compressed_depth import quantisation
from pyconnect.codecs.compressed_image import CompressedImageCodec, decode_compressed_image
from pyconnect.codecs.point_cloud import PointCloudCodec, decode_point_cloud
from pyconnect.errors import EncodeError

DEPTH = CompressedImageCodec(format="compressedDepth")


def test_compressed_depth_16uc1_round_trip_and_image_transport_bytes() -> None:
    depth = np.array([[0, 500, 1000], [9999, 10000, 10001]], np.uint16)
    msg = DEPTH.encode(depth)
    assert msg.format == "16UC1; compressedDepth png"
    data = bytes(msg.data)
    assert struct.unpack_from("<iff", data) == (0, 0.0, 0.0)
    png = cv2.imdecode(np.frombuffer(data[12:], np.uint8), cv2.IMREAD_UNCHANGED)
    assert png.dtype == np.uint16  # 16-bit PNG stays 16-bit
    # image_transport's depth_max filter: above 10 m (10000 mm) becomes 0.
    expected = depth.copy()
    expected[1, 2] = 0
    assert np.array_equal(decode_compressed_image(msg), expected)
    assert depth[1, 2] == 10001  # the caller's array is untouched


def test_compressed_depth_32fc1_uses_image_transport_quantisation() -> None:
    depth = np.array([[0.5, 1.0, 2.5], [9.5, np.nan, 12.0], [0.0, -1.0, np.inf]], np.float32)
    msg = DEPTH.encode(depth)
    assert msg.format == "32FC1; compressedDepth png"
    quant_a, quant_b = struct.unpack_from("<ff", bytes(msg.data), 4)
    assert (quant_a, quant_b) == quantisation(10.0, 100.0)
    assert quant_a == pytest.approx(10100.0) and quant_b == pytest.approx(1.0 - 1010.0)
    inverse = cv2.imdecode(np.frombuffer(bytes(msg.data)[12:], np.uint8), cv2.IMREAD_UNCHANGED)
    # C++: (unsigned short)(A / d + B) for 0 < d < depth_max, else 0.
    assert inverse[0, 0] == int(np.float32(quant_a) / np.float32(0.5) + np.float32(quant_b))
    assert (inverse[1, 1:] == 0).all() and (inverse[2] == 0).all()
    decoded = decode_compressed_image(msg)
    assert decoded.dtype == np.float32
    finite = np.array([[1, 1, 1], [1, 0, 0], [0, 0, 0]], bool)
    assert np.allclose(decoded[finite], depth[finite], rtol=2e-3)
    assert np.isnan(decoded[~finite]).all()


def test_compressed_depth_options_and_errors() -> None:
    codec = CompressedImageCodec(format="compressedDepth", depth_max=2.0, depth_quantization=50.0)
    assert codec.png_level == 9
    msg = codec.encode(np.array([[1.0, 3.0]], np.float32))
    assert struct.unpack_from("<ff", bytes(msg.data), 4) == quantisation(2.0, 50.0)
    assert np.isnan(decode_compressed_image(msg)[0, 1])
    with pytest.raises(EncodeError) as caught:
        DEPTH.encode(np.zeros((2, 2, 3), np.uint8))
    assert str(caught.value) == (
        "CompressedImage: compressedDepth expects uint16 (16UC1) or float32 (32FC1) of shape "
        "(H, W), got uint8 of shape (2, 2, 3)"
    )
    with pytest.raises(EncodeError) as caught:
        CompressedImageCodec(format="compressedDepth", depth_max=0.0)
    assert str(caught.value) == (
        "CompressedImageCodec: depth_max and depth_quantization must be > 0, got 0.0 and 100.0"
    )


def test_compressed_depth_through_the_wire_codec() -> None:
    depth = np.arange(12, dtype=np.uint16).reshape(3, 4) * 100
    cdr = wire.from_dict(DEPTH.to_fields(depth), "sensor_msgs/msg/CompressedImage")
    assert np.array_equal(wire.decode(cdr, "sensor_msgs/msg/CompressedImage"), depth)


def test_sixteen_bit_png_stays_sixteen_bit() -> None:
    image = np.array([[0, 1, 65535], [256, 4096, 300]], np.uint16)
    msg = CompressedImageCodec(format="png").encode(image)
    decoded = decode_compressed_image(msg)
    assert decoded.dtype == np.uint16 and np.array_equal(decoded, image)
    colour = np.stack([image, image[::-1], image * 0], axis=-1)
    assert np.array_equal(
        decode_compressed_image(CompressedImageCodec(format="png").encode(colour)), colour
    )


def cloud_msg(fields: list[tuple[str, int, int]], point_step: int, height: int, width: int,
              data: bytes, *, row_step: int | None = None, dense: bool = True) -> Any:  # fmt: skip
    msg = PointCloud2(
        height=height, width=width, point_step=point_step,
        row_step=point_step * width if row_step is None else row_step, is_dense=dense,
        fields=[PointField(name=n, offset=o, datatype=d, count=1) for n, o, d in fields],
    )  # fmt: skip
    msg.data.frombytes(data)
    return msg


def test_unsorted_offsets() -> None:
    fields = [("z", 8, PointField.FLOAT32), ("x", 0, PointField.FLOAT32),
              ("y", 4, PointField.FLOAT32)]  # fmt: skip
    data = struct.pack("<3f3f", 1, 2, 3, 4, 5, 6)
    points = decode_point_cloud(cloud_msg(fields, 12, 1, 2, data))
    assert points.dtype.names == ("z", "x", "y")
    assert points["x"].tolist() == [1, 4] and points["z"].tolist() == [3, 6]
    again = PointCloudCodec().encode(points)
    assert [(f.name, f.offset) for f in again.fields] == [("z", 8), ("x", 0), ("y", 4)]
    assert bytes(again.data) == data


def test_ouster_48_byte_points_skip_their_padding() -> None:
    fields = [("x", 0, PointField.FLOAT32), ("y", 4, PointField.FLOAT32),
              ("z", 8, PointField.FLOAT32), ("intensity", 16, PointField.FLOAT32),
              ("t", 20, PointField.UINT32), ("reflectivity", 24, PointField.UINT16),
              ("ring", 26, PointField.UINT16), ("ambient", 28, PointField.UINT16),
              ("range", 32, PointField.UINT32)]  # fmt: skip
    rows = []
    for index in range(3):
        row = bytearray(b"\xee" * 48)  # padding bytes hold junk
        struct.pack_into("<3f", row, 0, index, index + 0.5, -index)
        struct.pack_into("<fIHHHxxI", row, 16, 7.0, index * 10, 3, index, 9, 1000 + index)
        rows.append(bytes(row))
    points = decode_point_cloud(cloud_msg(fields, 48, 1, 3, b"".join(rows)))
    assert points.dtype.itemsize == 48
    assert points["ring"].tolist() == [0, 1, 2]
    assert points["range"].tolist() == [1000, 1001, 1002]
    assert points["y"].tolist() == [0.5, 1.5, 2.5]


def test_organised_cloud_with_row_padding() -> None:
    fields = [("x", 0, PointField.FLOAT32), ("y", 4, PointField.FLOAT32)]
    # 2 rows of 3 points, each row padded to 32 bytes
    data = b"".join(struct.pack("<6f", *range(r * 6, r * 6 + 6)) + b"\0" * 8 for r in range(2))
    points = decode_point_cloud(cloud_msg(fields, 8, 2, 3, data, row_step=32))
    assert points.shape == (2, 3)
    assert points["x"].tolist() == [[0, 2, 4], [6, 8, 10]]
    msg = PointCloudCodec().encode(points)
    assert (msg.height, msg.width, msg.row_step) == (2, 3, 24)
    assert np.array_equal(decode_point_cloud(msg), points)


def test_not_dense_clouds_keep_their_nans() -> None:
    fields = [("x", 0, PointField.FLOAT32), ("y", 4, PointField.FLOAT32),
              ("z", 8, PointField.FLOAT32)]  # fmt: skip
    data = struct.pack("<6f", 1, 2, 3, float("nan"), float("nan"), float("nan"))
    points = decode_point_cloud(cloud_msg(fields, 12, 1, 2, data, dense=False))
    assert np.isnan(points["x"][1]) and points["x"][0] == 1
    msg = PointCloudCodec().encode(points)
    assert msg.is_dense is False
    assert PointCloudCodec().encode(points[:1]).is_dense is True
    assert bytes(msg.data) == data


def test_is_dense_false_through_the_wire() -> None:
    points = np.array([(1.0, np.nan, 2.0)], dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4")])
    cdr = wire.encode(points, "sensor_msgs/msg/PointCloud2")
    assert wire.to_dict(cdr, "sensor_msgs/msg/PointCloud2")["is_dense"] is False
    again = wire.decode(cdr, "sensor_msgs/msg/PointCloud2")
    assert np.isnan(again["y"][0]) and again["z"][0] == 2.0


def test_compressed_image_message_from_rclpy_decodes() -> None:
    msg = CompressedImage(format="16UC1; compressedDepth png")
    msg.data.frombytes(DEPTH.to_fields(np.ones((2, 2), np.uint16))["data"])
    assert decode_compressed_image(msg).tolist() == [[1, 1], [1, 1]]
