"""PointCloud2 ↔ structured arrays, checked against a per-point struct.unpack reader."""

from __future__ import annotations

import struct
from typing import Any

import numpy as np
import pytest
import sensor_msgs.msg as msgs
from hypothesis import given
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message

from pyconnect import codecs
from pyconnect.codecs.point_cloud import (
    PointCloudCodec,
    decode_point_cloud,
    pack_rgb,
    point_cloud_fields,
    unpack_rgb,
)
from pyconnect.errors import DecodeError, EncodeError
from tests.codecs.natural.helpers import EXAMPLES, same, wire_view

PointCloud2, PointField = msgs.PointCloud2, msgs.PointField

STRUCT = {1: "b", 2: "B", 3: "h", 4: "H", 5: "i", 6: "I", 7: "f", 8: "d"}
SIZES = {1: 1, 2: 1, 3: 2, 4: 2, 5: 4, 6: 4, 7: 4, 8: 8}


def read_points_struct(msg: Any) -> list[list[dict[str, tuple[Any, ...]]]]:
    """Independent reader: every point of every row, every field unpacked with struct."""
    order = ">" if msg.is_bigendian else "<"
    data = bytes(msg.data)
    rows = []
    for row in range(msg.height):
        points = []
        for col in range(msg.width):
            base = row * msg.row_step + col * msg.point_step
            point = {}
            for field in msg.fields:
                fmt = f"{order}{field.count}{STRUCT[field.datatype]}"
                point[field.name] = struct.unpack_from(fmt, data, base + field.offset)
            points.append(point)
        rows.append(points)
    return rows


def agrees(decoded: np.ndarray, msg: Any) -> bool:
    expected = read_points_struct(msg)
    grid = decoded.reshape(msg.height, msg.width) if msg.height and msg.width else decoded
    for row, points in enumerate(expected):
        for col, point in enumerate(points):
            for name, values in point.items():
                ours = np.atleast_1d(grid[row, col][name]).tolist()
                if any(
                    struct.pack("<d", float(a)) != struct.pack("<d", float(b))
                    for a, b in zip(ours, values, strict=True)
                ):
                    return False
    return True


@st.composite
def clouds(draw: st.DrawFn) -> Any:
    count = draw(st.integers(1, 4))
    fields = []
    offset = 0
    names = ["x", "y", "z", "intensity", "ring", "t", "rgb", "normal"][:count]
    for name in names:
        datatype = draw(st.integers(1, 8))
        field_count = draw(st.sampled_from([1, 1, 2, 3]))
        offset += draw(st.sampled_from([0, 0, 1, 4]))  # gaps between fields
        fields.append((name, offset, datatype, field_count))
        offset += SIZES[datatype] * field_count
    point_step = offset + draw(st.sampled_from([0, 0, 3, 16]))  # trailing padding
    if draw(st.booleans()):
        fields = draw(st.permutations(fields))  # unsorted offsets
    height = draw(st.sampled_from([1, 1, 2, 3]))
    width = draw(st.integers(0, 5))
    row_step = width * point_step + draw(st.sampled_from([0, 0, 5]))
    big = draw(st.booleans())
    data = draw(st.binary(min_size=row_step * height, max_size=row_step * height))
    msg = PointCloud2(
        height=height,
        width=width,
        is_bigendian=big,
        point_step=point_step,
        row_step=row_step,
        fields=[PointField(name=n, offset=o, datatype=d, count=c) for n, o, d, c in fields],
    )
    msg.data.frombytes(data)
    return msg


@EXAMPLES
@given(clouds())
def test_decode_agrees_with_a_struct_reader(msg: Any) -> None:
    decoded = decode_point_cloud(msg)
    assert decoded.shape == ((msg.width,) if msg.height == 1 else (msg.height, msg.width))
    assert agrees(decoded, msg)
    assert agrees(decode_point_cloud(wire_view(msg)), msg)
    if decoded.size:
        assert np.shares_memory(decoded, np.frombuffer(msg.data, np.uint8))


@EXAMPLES
@given(clouds())
def test_round_trip_keeps_fields_offsets_padding_and_byte_order(msg: Any) -> None:
    codec = PointCloudCodec()
    decoded = codec.decode(msg)
    again = codec.encode(decoded)
    assert [(f.name, f.offset, f.datatype, f.count) for f in again.fields] == [
        (f.name, f.offset, f.datatype, f.count) for f in msg.fields
    ]
    assert (again.point_step, again.height, again.width) == (
        msg.point_step,
        msg.height,
        msg.width,
    )
    if any(SIZES[f.datatype] > 1 for f in msg.fields):  # one-byte fields have no byte order
        assert again.is_bigendian == msg.is_bigendian
    assert same(codec.decode(again), decoded)
    assert agrees(codec.decode(again), again)


def test_xyz_array_encodes_as_float_fields() -> None:
    xyz = np.array([[1.0, 2.0, 3.0], [4.0, np.nan, 6.0]], np.float32)
    msg = PointCloudCodec().encode(xyz)
    assert [(f.name, f.offset, f.datatype, f.count) for f in msg.fields] == [
        ("x", 0, 7, 1),
        ("y", 4, 7, 1),
        ("z", 8, 7, 1),
    ]
    assert (msg.point_step, msg.row_step, msg.height, msg.width) == (12, 24, 1, 2)
    assert msg.is_dense is False
    decoded = decode_point_cloud(msg)
    assert decoded["x"].tolist() == [1.0, 4.0] and np.isnan(decoded["y"][1])
    dense = PointCloudCodec().encode(np.zeros((3, 3)))
    assert dense.is_dense is True and dense.fields[0].datatype == 8
    # a big-endian (N, 3) array is converted to native order, not reinterpreted
    swapped = PointCloudCodec().encode(np.array([[1.0, 2.0, 3.0]], ">f4"))
    assert swapped.is_bigendian is False
    assert decode_point_cloud(swapped).tolist() == [(1.0, 2.0, 3.0)]


def test_ouster_like_padding_and_rgb() -> None:
    dtype = np.dtype(
        {
            "names": ["x", "y", "z", "intensity", "rgb", "ring"],
            "formats": ["<f4", "<f4", "<f4", "<f4", "<f4", "<u2"],
            "offsets": [0, 4, 8, 16, 20, 24],
            "itemsize": 48,
        }
    )
    points = np.zeros(4, dtype)
    points["x"] = [1, 2, 3, 4]
    colours = np.array([[255, 0, 0], [0, 255, 0], [0, 0, 255], [1, 2, 3]], np.uint8)
    points["rgb"] = pack_rgb(colours)
    msg = PointCloudCodec().encode(points)
    assert msg.point_step == 48 and len(msg.data) == 192
    decoded = decode_point_cloud(msg)
    assert decoded.dtype == dtype
    assert unpack_rgb(decoded["rgb"]).tolist() == colours.tolist()
    assert agrees(decoded, msg)


def test_errors_name_the_field() -> None:
    msg = PointCloud2(
        height=1,
        width=2,
        point_step=4,
        row_step=8,
        fields=[PointField(name="x", offset=0, datatype=7, count=1)],
    )
    msg.data.frombytes(bytes(5))
    with pytest.raises(DecodeError) as short:
        decode_point_cloud(msg)
    assert str(short.value) == (
        "PointCloud2.data: expected at least 8 bytes (row_step 8 * height 1), got 5"
    )
    msg.fields = [PointField(name="x", offset=2, datatype=7, count=1)]
    with pytest.raises(DecodeError) as overflow:
        decode_point_cloud(msg)
    assert str(overflow.value) == ("PointCloud2.fields['x']: bytes 2..6 do not fit in point_step 4")
    msg.fields = [PointField(name="x", offset=0, datatype=9, count=1)]
    with pytest.raises(DecodeError) as datatype:
        decode_point_cloud(msg)
    assert str(datatype.value) == (
        "PointCloud2.fields['x'].datatype: expected 1-8 (INT8..FLOAT64), got 9"
    )
    with pytest.raises(EncodeError) as not_array:
        point_cloud_fields([[1.0, 2.0, 3.0]])
    assert str(not_array.value) == (
        "PointCloud2: expected a structured ndarray or an (N, 3) float array, got list"
    )
    with pytest.raises(EncodeError) as bad_dtype:
        point_cloud_fields(np.zeros(2, [("x", "<f2")]))
    assert str(bad_dtype.value) == (
        "PointCloud2.fields['x']: expected int8, uint8, int16, uint16, int32, uint32, float32 "
        "or float64, got float16"
    )


XYZ_RGB = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("rgb", "<f4")])
ODD_WORDS = [np.nan, np.inf, -np.inf, 3.0e38, 1.0e20, 0.0]  # non-finite, or squares overflow


@EXAMPLES
@given(
    count=st.sampled_from([0, 1, 7, 300_000]),
    spots=st.lists(
        st.tuples(
            st.floats(0, 1, exclude_max=True),
            st.sampled_from(["x", "y", "z", "rgb"]),
            st.sampled_from(ODD_WORDS),
        ),
        max_size=3,
    ),
)
def test_is_dense_in_one_pass_agrees_with_a_per_axis_check(count: int, spots: Any) -> None:
    """The words check (sum of squares, then per axis if that is not finite) against
    ``isfinite`` per axis, on both encode paths: NaN/inf in x, y or z clears is_dense; in rgb,
    or a huge finite coordinate (its square overflows), it does not."""
    points = np.zeros(count, XYZ_RGB)
    for where, name, value in spots:
        if count:
            points[name][int(where * count)] = value
    expected = all(bool(np.isfinite(points[axis]).all()) for axis in "xyz")
    msg = PointCloudCodec().encode(points)
    assert msg.is_dense is expected
    assert bytes(msg.data) == points.tobytes()
    assert point_cloud_fields(points)["is_dense"] is expected
    if count > 1:
        even = points[: count // 2 * 2]
        organised = PointCloudCodec().encode(even.reshape(2, -1))
        assert organised.is_dense is all(bool(np.isfinite(even[axis]).all()) for axis in "xyz")


def test_is_dense_of_float64_and_strided_points_uses_the_per_axis_check() -> None:
    wide = np.zeros(5, [("x", "<f8"), ("y", "<f8"), ("z", "<f8")])
    wide["z"][4] = np.nan
    assert PointCloudCodec().encode(wide).is_dense is False
    assert PointCloudCodec().encode(wide[:4]).is_dense is True
    every_other = np.zeros(10, XYZ_RGB)
    every_other["y"][1] = np.inf
    assert PointCloudCodec().encode(every_other[::2]).is_dense is True
    assert PointCloudCodec().encode(every_other[1::2]).is_dense is False


def test_encoded_message_is_rclpys_own() -> None:
    """The data is rclpy's array('B') (grown chunk by chunk): the message equals, serialises
    and converts to a dict as one rclpy built."""
    from array import array

    from rclpy.serialization import deserialize_message, serialize_message

    from pyconnect import codecs

    points = np.zeros(9_000, XYZ_RGB)  # several chunks when the chunk is small
    points["x"] = np.arange(9_000)
    msg = PointCloudCodec().encode(points)
    reference = msgs.PointCloud2(
        height=1, width=9_000, fields=msg.fields, point_step=16, row_step=16 * 9_000,
        is_dense=True,
    )  # fmt: skip
    reference.data = array("B", points.tobytes())
    assert msg == reference
    assert reference == msg
    assert deserialize_message(serialize_message(msg), msgs.PointCloud2) == reference
    assert type(msg.data) is array and msg.data.typecode == "B"
    assert codecs.to_dict(msg) == codecs.to_dict(reference)


def test_chunked_copy_is_exact_across_chunk_boundaries(monkeypatch: pytest.MonkeyPatch) -> None:
    from pyconnect.codecs import point_cloud

    monkeypatch.setattr(point_cloud, "_CHUNK", 64)  # 4 points a chunk, 250 chunks
    points = np.zeros(1_001, XYZ_RGB)
    points["y"] = np.arange(1_001)
    data, dense = point_cloud.copy_checking_dense(points)
    assert (bytes(data), dense) == (points.tobytes(), True)
    points["z"][1_000] = np.nan  # in the last, partial chunk
    data, dense = point_cloud.copy_checking_dense(points)
    assert (bytes(data), dense) == (points.tobytes(), False)


PADDED = np.dtype(
    {"names": ["x", "y", "z", "intensity"], "formats": ["<f4"] * 4, "offsets": [0, 4, 8, 16],
     "itemsize": 32}
)  # fmt: skip


def _padded_points(count: int) -> tuple[np.ndarray, np.ndarray]:
    """Points with a recognisable pattern in their padding, and their raw bytes per point."""
    raw = np.full((count, 32), 0xA5, np.uint8)
    points = raw.reshape(-1).view(PADDED)
    points["x"] = np.arange(count)
    points["intensity"] = 2.0
    return points, raw


def test_strided_padded_points_encode_their_own_bytes() -> None:
    # ascontiguousarray copies a structured array's fields only: the padding was heap garbage.
    points, raw = _padded_points(2000)
    view = points[::2]
    expected = raw[::2].tobytes()
    codec = PointCloudCodec()
    assert bytes(codec.encode(view).data) == expected
    assert bytes(point_cloud_fields(view)["data"]) == expected
    cdr = codecs.wire.encode(view, "sensor_msgs/msg/PointCloud2")
    assert bytes(deserialize_message(cdr, PointCloud2).data) == expected
    organised = points.reshape(40, 50)[:, ::5]
    assert bytes(codec.encode(organised).data) == raw.reshape(40, 50, 32)[:, ::5].tobytes()


def test_unpack_rgb_reads_integer_and_float_fields_bit_for_bit() -> None:
    expected = [[0x10, 0x20, 0x30], [0xFF, 0x80, 0x00]]
    for kind in ("<u4", ">u4", "<i4"):
        rgba = np.array([0xFF102030, 0xFFFF8000], np.uint32).astype(kind)
        assert unpack_rgb(rgba).tolist() == expected
    packed = pack_rgb(np.array(expected, np.uint8))
    assert unpack_rgb(packed).tolist() == expected
    assert unpack_rgb(packed.astype(">f4")).tolist() == expected
    cloud = np.zeros(2, [("x", "<f4"), ("rgba", "<u4")])
    cloud["rgba"] = [0xFF102030, 0xFFFF8000]
    assert unpack_rgb(cloud["rgba"]).tolist() == expected  # a strided field view
    with pytest.raises(TypeError) as error:
        unpack_rgb(np.zeros(2, np.int64))
    assert str(error.value) == (
        "unpack_rgb: expected a float or 4-byte integer rgb field, got int64 (<i8)"
    )


def test_unpack_rgb_reads_other_floats_as_float32() -> None:
    # A packed rgb in a float64 column (a parquet or pandas export), a list or a Python float
    # holds a float32's value: narrowing it gives back the bits, as it did before the
    # bit-for-bit reading of float32 and integer fields.
    expected = [[255, 128, 16], [0x10, 0x20, 0x30]]
    packed = pack_rgb(np.array(expected, np.uint8))
    assert unpack_rgb(packed.astype(np.float64)).tolist() == expected
    assert unpack_rgb(packed.astype(">f8")).tolist() == expected
    assert unpack_rgb([float(value) for value in packed]).tolist() == expected
    assert unpack_rgb(float(packed[0])).tolist() == expected[0]


def test_unnamed_fields_get_sensor_msgs_pys_names() -> None:
    msg = PointCloud2(height=1, width=2, point_step=16, row_step=32)
    msg.fields = [
        PointField(name="x", offset=0, datatype=7, count=1),
        PointField(name="", offset=4, datatype=7, count=1),
        PointField(name="z", offset=8, datatype=7, count=1),
        PointField(name="", offset=12, datatype=6, count=1),
    ]
    msg.data.frombytes(np.arange(8, dtype="<u4").tobytes())
    cloud = decode_point_cloud(msg)
    assert cloud.dtype.names == ("x", "unnamed_field_1", "z", "unnamed_field_3")
    assert cloud["unnamed_field_3"].tolist() == [3, 7]
    msg.fields[1].name = "unnamed_field_3"
    with pytest.raises(DecodeError) as error:
        decode_point_cloud(msg)
    assert str(error.value) == "PointCloud2.fields: field 'unnamed_field_3' appears more than once"


def test_field_titles_add_no_fields_on_either_path() -> None:
    # numpy lists a titled field twice in dtype.fields (by name and by title); sensor_msgs_py's
    # dtype_to_fields, like ours, takes one PointField per name.
    dtype = np.dtype(
        {
            "names": ["x", "y", "z"],
            "formats": ["<f4"] * 3,
            "offsets": [0, 4, 8],
            "titles": ["X (m)", None, None],
            "itemsize": 12,
        }
    )
    points = np.zeros(2, dtype)
    points["x"] = [1.0, 2.0]
    expected = [("x", 0, 7, 1), ("y", 4, 7, 1), ("z", 8, 7, 1)]
    msg = PointCloudCodec().encode(points)
    assert [(f.name, f.offset, f.datatype, f.count) for f in msg.fields] == expected
    assert decode_point_cloud(msg).dtype.names == ("x", "y", "z")
    cloud = "sensor_msgs/msg/PointCloud2"
    table = codecs.wire.to_dict(codecs.wire.encode(points, cloud), cloud)
    assert [
        (f["name"], f["offset"], f["datatype"], f["count"]) for f in table["fields"]
    ] == expected
    assert decode_point_cloud(msg)["x"].tolist() == [1.0, 2.0]


def test_a_stream_of_distinct_field_tables_does_not_grow_the_dtype_cache() -> None:
    """Field tables come off the wire: each distinct one was kept for good (a peer sending a new
    field name per message grew memory without bound)."""
    from types import SimpleNamespace

    from pyconnect.codecs import point_cloud

    for index in range(300):
        field = SimpleNamespace(name=f"f{index}", offset=0, datatype=7, count=1)
        dtype = point_cloud.cloud_dtype([field], 4)
        assert dtype.names == (f"f{index}",)
    assert len(point_cloud._DTYPES) <= 256  # image.py's bound for its layouts too
