"""geometry_msgs Polygon ↔ float32 (N, 3) array; PoseArray and nav_msgs/Path ↔ lists of poses.

Polygon is lossless for received messages (float32 values); Path drops the header of every
pose (its ``lossless`` is False).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from pyconnect.codecs.base import check_message_type, decode_failure
from pyconnect.codecs.geometry import (
    GeometryCodec,
    PoseCodec,
    PoseValue,
    pose_parts,
    xyz_fields,
    xyzw_fields,
)
from pyconnect.errors import DecodeError, EncodeError, type_name_of


class PolygonCodec(GeometryCodec):
    """geometry_msgs/Polygon ↔ float32 (N, 3) array of its points."""

    msg_type = "geometry_msgs/msg/Polygon"
    _name = "Polygon"

    def __init__(self) -> None:
        super().__init__()
        self._classes: set[type] = set()

    def decode(self, msg: Any) -> npt.NDArray[np.float32]:
        if type(msg) not in self._classes:  # once per class; noise next to the loop below
            check_message_type(msg, self.msg_type)  # a sensor_msgs/PointCloud has points too
            self._classes.add(type(msg))
        try:
            points = msg.points
            result = np.empty((len(points), 3), np.float32)
            for index, point in enumerate(points):
                result[index] = (point.x, point.y, point.z)
        except (AttributeError, TypeError) as error:  # free until raised: a class, a Point()
            raise decode_failure(error, msg, self.msg_type) from None
        return result

    def _checked(self, value: Any) -> npt.NDArray[np.float32]:
        if isinstance(value, list | tuple) and not value:
            return np.empty((0, 3), np.float32)
        try:
            array = np.asarray(value)
        except (TypeError, ValueError) as error:  # ragged input
            raise EncodeError(
                f"{self._name}.points: expected an (N, 3) array, got {type_name_of(value)}"
            ) from error
        if array.ndim != 2 or array.shape[1] != 3 or array.dtype.kind not in "iuf":
            raise EncodeError(
                f"{self._name}.points: expected an (N, 3) array of floats, got "
                f"{type_name_of(value)} of shape {array.shape} and dtype {array.dtype}"
            )
        if array.dtype.kind == "f" and array.dtype.itemsize > 4:
            finite = array[np.isfinite(array)]
            if finite.size and np.abs(finite).max() > np.finfo(np.float32).max:
                raise EncodeError(f"{self._name}.points: values exceed the float32 range")
        return array.astype(np.float32, copy=False)

    def to_fields(self, value: Any) -> dict[str, Any]:
        array = self._checked(value)
        return {"points": [{"x": x, "y": y, "z": z} for x, y, z in array.tolist()]}


class PoseArrayCodec(GeometryCodec):
    """geometry_msgs/PoseArray ↔ list of pose tuples (drops the header)."""

    msg_type = "geometry_msgs/msg/PoseArray"
    _name = "PoseArray"
    lossless = False
    _pose = PoseCodec()

    def decode(self, msg: Any) -> list[PoseValue]:
        decode = self._pose.decode
        try:
            return [decode(pose) for pose in msg.poses]
        except (AttributeError, TypeError, DecodeError) as error:  # free until raised
            raise decode_failure(error, msg, self.msg_type) from None

    def _list(self, value: Any) -> list[Any]:
        if not isinstance(value, list | tuple):
            raise EncodeError(
                f"{self._name}.poses: expected a list of poses, got {type_name_of(value)}"
            )
        return list(value)

    def to_fields(self, value: Any) -> dict[str, Any]:
        return {
            "poses": [
                _pose_fields(pose, f"{self._name}.poses[{i}]")
                for i, pose in enumerate(self._list(value))
            ]
        }


def _pose_fields(value: Any, path: str) -> dict[str, Any]:
    p, q = pose_parts(value, path, "position", "orientation")
    return {"position": xyz_fields(p), "orientation": xyzw_fields(q)}


class PathCodec(PoseArrayCodec):
    """nav_msgs/Path ↔ list of pose tuples (drops its header and every pose's header)."""

    msg_type = "nav_msgs/msg/Path"
    _module = "nav_msgs"
    _name = "Path"
    _class: Any = None

    def decode(self, msg: Any) -> list[PoseValue]:
        decode = self._pose.decode
        try:
            return [decode(stamped.pose) for stamped in msg.poses]
        except (AttributeError, TypeError, DecodeError) as error:  # free until raised
            raise decode_failure(error, msg, self.msg_type) from None

    def to_fields(self, value: Any) -> dict[str, Any]:
        return {
            "poses": [
                {"pose": _pose_fields(pose, f"Path.poses[{i}]")}
                for i, pose in enumerate(self._list(value))
            ]
        }
