"""geometry_msgs Polygon ↔ float32 (N, 3) array; PoseArray and nav_msgs/Path ↔ lists of poses.

Polygon is lossless for received messages (float32 values); Path drops the header of every
pose (its ``lossless`` is False).
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import chain
from typing import Any, NoReturn

import numpy as np
import numpy.typing as npt

from pyconnect.codecs.base import check_message_type, decode_failure
from pyconnect.codecs.field_checks import check_float
from pyconnect.codecs.geometry import (
    GeometryCodec,
    PoseCodec,
    PoseValue,
    pose_parts,
    xyz_fields,
    xyzw_fields,
)
from pyconnect.errors import DecodeError, EncodeError, type_name_of
from pyconnect.typesys.primitives import FLOAT32_OVERFLOW

# Element types a list of points may hold as they are: np.asarray also takes a bool for 1.0.
_NUMBER_TYPES = (int, float, np.integer, np.floating)


def _only_numbers(rows: Sequence[Any]) -> bool:
    """Whether the rows of an (N, 3) list hold only numbers: a C-level pass collects the
    element types, of which there are one or two to test."""
    return all(
        issubclass(kind, _NUMBER_TYPES) and not issubclass(kind, bool)
        for kind in set(map(type, chain.from_iterable(rows)))
    )


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
        if not isinstance(value, np.ndarray) and not _only_numbers(value):
            # np.asarray took a bool among floats as 1.0: name it, as Point32 would.
            self._element_error(value)
        with np.errstate(over="ignore"):  # what does not fit is named below
            cast = array.astype(np.float32, copy=False)
        if array.dtype.kind == "f" and array.dtype.itemsize > 4 and np.isinf(cast).any():
            self._overflow_error(array, cast)
        return cast

    def _element_error(self, rows: Sequence[Any]) -> NoReturn:
        # Only reached when the type test failed: find the element that made it fail.
        for index, row in enumerate(rows):
            for axis, element in zip("xyz", row, strict=True):
                check_float(element, f"{self._name}.points[{index}].{axis}")
        raise EncodeError(f"{self._name}.points: expected an (N, 3) array of floats")

    def _overflow_error(self, array: npt.NDArray[Any], cast: npt.NDArray[np.float32]) -> None:
        # A finite float64 past float32's range became inf; check_float32's bound and words.
        overflow = np.flatnonzero(np.isinf(cast) & np.isfinite(array))
        if overflow.size:
            index, axis = divmod(int(overflow[0]), 3)
            raise EncodeError(
                f"{self._name}.points[{index}].{'xyz'[axis]}: expected float32 "
                f"(|x| < {FLOAT32_OVERFLOW!r}), got {float(array[index, axis])!r}"
            )

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
