"""nav_msgs/OccupancyGrid ↔ ``OccupancyGridValue``: an int8 (H, W) array plus resolution and origin.

``cells[row, col]`` is the occupancy (0-100, -1 unknown) of the cell at ``origin`` +
``(col, row) * resolution``; the array is a zero-copy view where the buffer allows. The map
metadata is kept (``origin`` as a pose tuple, ``map_load_time`` as ``RosTime``); the header is
dropped (use ``stamped=True``), so ``lossless`` is False.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from pyconnect.codecs.base import FieldsCodec, decode_failure
from pyconnect.codecs.buffers import numeric_view
from pyconnect.codecs.builtin_time import RosTime, time_fields
from pyconnect.codecs.field_checks import check_float32
from pyconnect.codecs.field_path import rerooted
from pyconnect.codecs.geometry import PoseCodec, PoseValue
from pyconnect.errors import DecodeError, EncodeError, type_name_of

_POSE = PoseCodec()
_EPOCH = RosTime(0, 0)


def _empty() -> npt.NDArray[np.int8]:
    return np.empty((0, 0), np.int8)


@dataclass(frozen=True, eq=False)
class OccupancyGridValue:
    """A map: ``cells`` (int8, rows x columns), metres per cell, and the pose of cell (0, 0)."""

    cells: npt.NDArray[np.int8] = field(default_factory=_empty)
    resolution: float = 0.0
    origin: PoseValue = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    map_load_time: RosTime = _EPOCH

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, OccupancyGridValue):
            return NotImplemented
        return (
            self.cells.shape == other.cells.shape
            and bool(np.array_equal(self.cells, other.cells))
            and self.resolution == other.resolution
            and self.origin == other.origin
            and self.map_load_time == other.map_load_time
        )

    __hash__ = None  # type: ignore[assignment]


def decode_occupancy_grid(msg: Any) -> OccupancyGridValue:
    try:
        info = msg.info
        height, width = info.height, info.width
        data = numeric_view(msg.data, np.int8)
        load = info.map_load_time
        origin = _POSE.decode(info.origin)
    except (AttributeError, TypeError, DecodeError) as error:  # free until raised: a class
        raise decode_failure(error, msg, "nav_msgs/msg/OccupancyGrid") from None
    if len(data) != height * width:
        raise DecodeError(
            f"OccupancyGrid.data: expected {height * width} cells (height {height} * width "
            f"{width}), got {len(data)}"
        )
    return OccupancyGridValue(
        data.reshape(height, width),
        info.resolution,
        origin,
        RosTime(load.sec, load.nanosec),
    )


def _checked(value: Any) -> tuple[OccupancyGridValue, npt.NDArray[np.int8]]:
    if not isinstance(value, OccupancyGridValue):
        raise EncodeError(f"OccupancyGrid: expected OccupancyGridValue, got {type_name_of(value)}")
    cells = np.asarray(value.cells)
    if cells.ndim != 2 or cells.dtype != np.int8:
        raise EncodeError(
            f"OccupancyGrid.data: expected an int8 (H, W) array, got {cells.dtype} of shape "
            f"{cells.shape}"
        )
    return value, cells


class OccupancyGridCodec(FieldsCodec):
    """nav_msgs/OccupancyGrid ↔ ``OccupancyGridValue``."""

    msg_type = "nav_msgs/msg/OccupancyGrid"
    lossless = False

    decode = staticmethod(decode_occupancy_grid)

    def to_fields(self, value: Any) -> dict[str, Any]:
        grid, cells = _checked(value)
        return {
            "info": {
                "map_load_time": time_fields(
                    grid.map_load_time, "OccupancyGrid.info.map_load_time"
                ),
                "resolution": check_float32(grid.resolution, "OccupancyGrid.info.resolution"),
                "width": cells.shape[1],
                "height": cells.shape[0],
                "origin": _origin_fields(grid.origin),
            },
            "data": np.ascontiguousarray(cells).reshape(-1),
        }


def _origin_fields(origin: Any) -> dict[str, Any]:
    try:
        return _POSE.to_fields(origin)
    except EncodeError as error:  # named from Pose: OccupancyGrid.info.origin.orientation
        raise rerooted(error, "Pose", "OccupancyGrid.info.origin") from None
