"""LaserScan, OccupancyGrid and the std_msgs MultiArrays ↔ ndarray-centred values."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
import std_msgs.msg as std_msgs
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from pyconnect import codecs
from pyconnect.codecs.builtin_time import RosTime
from pyconnect.codecs.laser_scan import LaserScanValue, scan_points
from pyconnect.codecs.multi_array import DTYPES
from pyconnect.codecs.occupancy_grid import OccupancyGridValue
from pyconnect.errors import DecodeError, EncodeError
from tests.codecs.natural.helpers import EXAMPLES, same, wire_view

f32 = st.floats(width=32)


@st.composite
def scans(draw: st.DrawFn) -> LaserScanValue:
    n = draw(st.integers(0, 20))
    return LaserScanValue(
        draw(hnp.arrays(np.float32, n, elements=f32)),
        draw(hnp.arrays(np.float32, draw(st.sampled_from([0, n])), elements=f32)),
        *(draw(f32) for _ in range(7)),
    )


@EXAMPLES
@given(scans())
def test_laser_scan_round_trip(scan: LaserScanValue) -> None:
    codec = codecs.lookup("sensor_msgs/LaserScan")
    msg = codec.encode(scan)
    decoded = codec.decode(msg)
    assert same(decoded, scan)
    assert np.shares_memory(decoded.ranges, np.frombuffer(msg.ranges, np.float32)) or not len(
        msg.ranges
    )
    assert same(codec.decode(wire_view(msg)), scan)
    assert same(
        codec.decode(codecs.from_dict(codec.to_fields(scan), "sensor_msgs/LaserScan")), scan
    )


def test_scan_points() -> None:
    scan = LaserScanValue(
        np.array([1.0, 2.0, np.inf, 0.05], np.float32),
        angle_min=0.0,
        angle_increment=np.pi / 2,
        range_min=0.1,
        range_max=10.0,
    )
    points = scan_points(scan)
    assert np.allclose(points, [[1.0, 0.0], [0.0, 2.0]], atol=1e-12)
    assert scan_points(scan, keep_invalid=True).shape == (4, 2)


def test_laser_scan_errors() -> None:
    with pytest.raises(EncodeError) as error:
        codecs.encode({"ranges": []}, "sensor_msgs/LaserScan")
    assert str(error.value) == "LaserScan: expected LaserScanValue, got dict"
    # Ranges and intensities are checked element by element, as a float32[] field anywhere.
    for ranges, text in [
        (["a"], "LaserScan.ranges[0]: expected float, got str"),
        ([1.0, True], "LaserScan.ranges[1]: expected float, got bool"),
        ([1.0, 2.0, 1e39], "LaserScan.ranges[2]: expected float32 (|x| < 3.4028235677973366e+38), got 1e+39"),
        (np.array([1e39]), "LaserScan.ranges[0]: expected float32 (|x| < 3.4028235677973366e+38), got 1e+39"),
        (np.zeros((2, 2), np.float32), "LaserScan.ranges: expected a 1-D sequence, got shape (2, 2)"),
        ("12", "LaserScan.ranges: expected list, got str"),
    ]:
        with pytest.raises(EncodeError) as bad:
            codecs.encode(LaserScanValue(ranges=ranges), "sensor_msgs/LaserScan")
        assert str(bad.value) == text
    with pytest.raises(EncodeError) as bad:
        codecs.encode(LaserScanValue(intensities=[0, None]), "sensor_msgs/LaserScan")
    assert str(bad.value) == "LaserScan.intensities[1]: expected float, got NoneType"
    # ints and float64 arrays are converted, as the generated codecs convert them
    scan = codecs.decode(codecs.encode(LaserScanValue(ranges=[1, 2.5]), "sensor_msgs/LaserScan"))
    assert scan.ranges.tolist() == [1.0, 2.5] and scan.ranges.dtype == np.float32


@st.composite
def grids(draw: st.DrawFn) -> OccupancyGridValue:
    shape = (draw(st.integers(0, 5)), draw(st.integers(0, 6)))
    return OccupancyGridValue(
        draw(hnp.arrays(np.int8, shape)),
        draw(f32),
        (
            (draw(st.floats()), draw(st.floats()), draw(st.floats())),
            (draw(st.floats()), draw(st.floats()), draw(st.floats()), draw(st.floats())),
        ),
        RosTime(draw(st.integers(-(2**31), 2**31 - 1)), draw(st.integers(0, 2**32 - 1))),
    )


@EXAMPLES
@given(grids())
def test_occupancy_grid_round_trip(grid: OccupancyGridValue) -> None:
    codec = codecs.lookup("nav_msgs/OccupancyGrid")
    msg = codec.encode(grid)
    assert (msg.info.height, msg.info.width) == grid.cells.shape
    assert same(codec.decode(msg), grid)
    assert same(codec.decode(wire_view(msg)), grid)
    assert same(
        codec.decode(codecs.from_dict(codec.to_fields(grid), "nav_msgs/OccupancyGrid")), grid
    )


def test_occupancy_grid_errors() -> None:
    msg = codecs.encode(OccupancyGridValue(np.zeros((2, 3), np.int8)), "nav_msgs/OccupancyGrid")
    msg.info.width = 4
    with pytest.raises(DecodeError) as error:
        codecs.decode(msg)
    assert str(error.value) == ("OccupancyGrid.data: expected 8 cells (height 2 * width 4), got 6")
    with pytest.raises(EncodeError) as bad:
        codecs.encode(OccupancyGridValue(np.zeros((2, 3), np.uint8)), "nav_msgs/OccupancyGrid")  # type: ignore[arg-type]
    assert str(bad.value) == (
        "OccupancyGrid.data: expected an int8 (H, W) array, got uint8 of shape (2, 3)"
    )


@st.composite
def multi_arrays(draw: st.DrawFn) -> tuple[str, np.ndarray]:
    name = draw(st.sampled_from(sorted(DTYPES)))
    shape = draw(hnp.array_shapes(min_dims=1, max_dims=3, min_side=0, max_side=4))
    return name, draw(hnp.arrays(np.dtype(DTYPES[name]), shape))


@EXAMPLES
@given(multi_arrays())
def test_multi_array_round_trip(case: tuple[str, np.ndarray]) -> None:
    name, array = case
    codec = codecs.lookup(f"std_msgs/{name}")
    msg = codec.encode(array)
    assert same(codec.decode(msg), array)
    assert same(codec.decode(wire_view(msg)), array)
    assert same(codec.decode(codecs.from_dict(codec.to_fields(array), f"std_msgs/{name}")), array)
    # A strided copy of the same values takes the general path; a flat array, the short one.
    fields = codec.to_fields(array)
    general = codec.to_fields(np.repeat(array, 2, axis=-1)[..., ::2])
    assert fields["layout"] == general["layout"]
    assert same(np.asarray(fields["data"]), np.asarray(general["data"]))


def test_multi_array_layout_with_offset_and_padding() -> None:
    # 2 x 3 matrix stored with rows padded to 4 elements, after a 1-element offset.
    msg = std_msgs.Float32MultiArray(
        layout=std_msgs.MultiArrayLayout(
            dim=[
                std_msgs.MultiArrayDimension(label="rows", size=2, stride=8),
                std_msgs.MultiArrayDimension(label="cols", size=3, stride=4),
            ],
            data_offset=1,
        ),
        data=[-1.0, 0.0, 1.0, 2.0, -1.0, 3.0, 4.0, 5.0, -1.0],
    )
    decoded = codecs.decode(msg)
    assert decoded.tolist() == [[0.0, 1.0, 2.0], [3.0, 4.0, 5.0]]
    assert np.shares_memory(decoded, np.frombuffer(msg.data, np.float32))
    assert codecs.decode(std_msgs.Int32MultiArray(data=[1, 2, 3])).tolist() == [1, 2, 3]
    msg.data = msg.data[:7]
    with pytest.raises(DecodeError) as error:
        codecs.decode(msg)
    assert str(error.value) == (
        "Float32MultiArray.data: layout (2, 3) with strides (4, 1) and offset 1 reads element "
        "7, got 7 elements"
    )


@EXAMPLES
@given(
    data=st.lists(st.integers(-(2**31), 2**31 - 1), max_size=12),
    size=st.integers(0, 14),
    stride=st.integers(0, 20),
    offset=st.integers(0, 14),
)
def test_one_dimension_is_the_slice_after_the_offset(
    data: list[int], size: int, stride: int, offset: int
) -> None:
    """A 1-D layout reads ``size`` elements from ``data_offset`` (its stride never matters)."""
    msg = std_msgs.Int32MultiArray(
        layout=std_msgs.MultiArrayLayout(
            dim=[std_msgs.MultiArrayDimension(label="x", size=size, stride=stride)],
            data_offset=offset,
        ),
        data=data,
    )
    if offset > len(data):
        with pytest.raises(DecodeError) as error:
            codecs.decode(msg)
        assert str(error.value) == (
            f"Int32MultiArray.layout.data_offset: {offset} is past the {len(data)} elements of "
            "data"
        )
        return
    if offset + size > len(data):
        with pytest.raises(DecodeError) as error:
            codecs.decode(msg)
        assert str(error.value) == (
            f"Int32MultiArray.data: layout ({size},) needs {size} elements after offset "
            f"{offset}, got {len(data) - offset}"
        )
        return
    codec = codecs.lookup("std_msgs/Int32MultiArray")
    for decoded in (codec.decode(msg), codec.decode(wire_view(msg))):
        assert decoded.tolist() == data[offset : offset + size]
        assert decoded.dtype == np.int32 and decoded.shape == (size,)
    decoded = codec.decode(msg)
    assert decoded.flags.writeable
    assert np.shares_memory(decoded, np.frombuffer(msg.data, np.int32)) or not size


@pytest.mark.parametrize("dims", [[], [std_msgs.MultiArrayDimension(label="x", size=0)]])
def test_an_offset_past_the_data_is_refused_on_both_paths(dims: list[Any]) -> None:
    """Without dims it gave an empty array; with a size-0 dim an error that contradicted itself
    ("needs 0 elements after offset 100, got 0")."""
    msg = std_msgs.Float32MultiArray(
        layout=std_msgs.MultiArrayLayout(dim=dims, data_offset=100), data=[1.0, 2.0, 3.0]
    )
    codec = codecs.lookup("std_msgs/Float32MultiArray")
    for source in (msg, wire_view(msg)):
        with pytest.raises(DecodeError) as error:
            codec.decode(source)
        assert str(error.value) == (
            "Float32MultiArray.layout.data_offset: 100 is past the 3 elements of data"
        )
    msg.layout.data_offset = 3  # just past the last element: nothing, rightly
    assert codec.decode(msg).tolist() == []


def test_multi_array_dtype_errors() -> None:
    with pytest.raises(EncodeError) as error:
        codecs.encode(np.zeros(3, np.float64), "std_msgs/Int32MultiArray")
    assert str(error.value) == "Int32MultiArray.data: expected int32 values, got float64"
    with pytest.raises(EncodeError) as narrowing:
        codecs.encode(np.zeros(3, np.int64), "std_msgs/Int32MultiArray")
    assert str(narrowing.value) == "Int32MultiArray.data: expected int32 values, got int64"
    with pytest.raises(EncodeError) as not_array:
        codecs.encode([1, 2], "std_msgs/Int32MultiArray")
    assert str(not_array.value) == "Int32MultiArray: expected numpy.ndarray, got list"
    widened = codecs.decode(codecs.encode(np.array([1, 2], np.int16), "std_msgs/Int32MultiArray"))
    assert widened.dtype == np.int32 and widened.tolist() == [1, 2]


def test_multi_array_layout_cannot_claim_more_than_its_data() -> None:
    # Zero strides would give a view of 2**40 elements over one float: copying it would try to
    # allocate terabytes. A layout off the wire may only describe the data it comes with.
    dims = [std_msgs.MultiArrayDimension(label=str(i), size=2**20, stride=0) for i in range(2)]
    msg = std_msgs.Float64MultiArray(layout=std_msgs.MultiArrayLayout(dim=dims), data=[1.0])
    with pytest.raises(DecodeError) as error:
        codecs.decode(msg)
    assert str(error.value) == (
        "Float64MultiArray.data: layout (1048576, 1048576) needs 1099511627776 elements after "
        "offset 0, got 1"
    )
    many = [std_msgs.MultiArrayDimension(label="d", size=1, stride=1) for _ in range(40)]
    msg = std_msgs.Float64MultiArray(layout=std_msgs.MultiArrayLayout(dim=many), data=[1.0])
    with pytest.raises(DecodeError) as too_many:
        codecs.decode(msg)
    assert (
        str(too_many.value)
        == "Float64MultiArray.layout.dim: expected at most 32 dimensions, got 40"
    )


@pytest.mark.parametrize(
    ("name", "value", "error"),
    [
        # float64 -> float32 made 1e300 an inf with only a numpy warning.
        ("Float32MultiArray", np.array([1.0, 1e300]),
         "Float32MultiArray.data[1]: expected float32 (|x| < 3.4028235677973366e+38), got 1e+300"),
        ("Float32MultiArray", np.array([[1.0, 2.0], [3.0, -1e300]]),
         "Float32MultiArray.data[1][1]: expected float32 (|x| < 3.4028235677973366e+38), got -1e+300"),
        ("UInt8MultiArray", np.array([True, False]), "UInt8MultiArray.data: expected uint8 values, got bool"),
        # No dimension to write: it came back of shape (1,).
        ("Float64MultiArray", np.array(2.5),
         "Float64MultiArray: expected an array of at least one dimension, got a 0-d array "
         "(value.reshape(1) sends one element)"),
    ],
)  # fmt: skip
def test_a_multi_array_that_would_change_on_the_way_is_refused(
    name: str, value: np.ndarray, error: str
) -> None:
    from pyconnect.codecs import wire

    with pytest.raises(EncodeError) as caught:
        codecs.encode(value, f"std_msgs/msg/{name}")
    assert str(caught.value) == error
    with pytest.raises(EncodeError) as caught:
        wire.encode(value, f"std_msgs/msg/{name}")
    assert str(caught.value) == error


def test_infinities_and_nan_still_narrow_to_float32() -> None:
    value = np.array([np.inf, -np.inf, np.nan, 1.5])
    back = codecs.decode(codecs.encode(value, "std_msgs/msg/Float32MultiArray"))
    assert np.array_equal(back, value.astype(np.float32), equal_nan=True)


@pytest.mark.parametrize("ndim", [32, 33, 64])
def test_multi_array_encodes_only_the_dimensions_its_decode_takes(ndim: int) -> None:
    # numpy 2 makes arrays of up to 64 dimensions; decode reads at most 32 from a layout.
    value = np.arange(2, dtype=np.float32).reshape((1,) * (ndim - 1) + (2,))
    full_name = "std_msgs/msg/Float32MultiArray"
    codec = codecs.lookup(full_name)
    if ndim <= 32:
        assert same(codec.decode(codec.encode(value)), value)
        assert same(codecs.wire.decode(codecs.wire.encode(value, full_name), full_name), value)
        return
    message = f"Float32MultiArray: expected an array of at most 32 dimensions, got {ndim}"
    with pytest.raises(EncodeError) as error:
        codec.encode(value)
    assert str(error.value) == message
    with pytest.raises(EncodeError) as error:
        codecs.wire.encode(value, full_name)
    assert str(error.value) == message
