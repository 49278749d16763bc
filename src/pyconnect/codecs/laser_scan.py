"""sensor_msgs/LaserScan ↔ ``LaserScanValue``: float32 ranges/intensities plus the scan geometry.

The arrays are zero-copy views on the message's buffers where the buffer protocol allows.
``scan_points(value)`` gives the (N, 2) Cartesian points of the valid returns. Drops the
header (use ``stamped=True``), so ``lossless`` is False.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from pyconnect.codecs.base import FieldsCodec, decode_failure
from pyconnect.codecs.buffers import filled_array, numeric_view
from pyconnect.codecs.field_checks import check_float32
from pyconnect.errors import EncodeError, type_name_of

_GEOMETRY = (
    "angle_min",
    "angle_max",
    "angle_increment",
    "time_increment",
    "scan_time",
    "range_min",
    "range_max",
)


def _empty() -> npt.NDArray[np.float32]:
    return np.empty(0, np.float32)


def arrays_equal(a: npt.NDArray[Any], b: npt.NDArray[Any]) -> bool:
    """Equal shape and values (NaN never equals, as for floats)."""
    return bool(a.shape == b.shape and np.array_equal(a, b))


@dataclass(frozen=True, eq=False)
class LaserScanValue:
    """One scan: ``ranges``/``intensities`` (float32 arrays) and its geometry in SI units."""

    ranges: npt.NDArray[np.float32] = field(default_factory=_empty)
    intensities: npt.NDArray[np.float32] = field(default_factory=_empty)
    angle_min: float = 0.0
    angle_max: float = 0.0
    angle_increment: float = 0.0
    time_increment: float = 0.0
    scan_time: float = 0.0
    range_min: float = 0.0
    range_max: float = 0.0

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, LaserScanValue):
            return NotImplemented
        return (
            arrays_equal(self.ranges, other.ranges)
            and arrays_equal(self.intensities, other.intensities)
            and all(getattr(self, k) == getattr(other, k) for k in _GEOMETRY)
        )

    __hash__ = None  # type: ignore[assignment]


def scan_points(scan: LaserScanValue, *, keep_invalid: bool = False) -> npt.NDArray[np.float64]:
    """The (N, 2) x/y points of a scan; returns outside [range_min, range_max] are dropped."""
    ranges = scan.ranges.astype(np.float64)
    angles = scan.angle_min + np.arange(len(ranges)) * scan.angle_increment
    points = np.stack((ranges * np.cos(angles), ranges * np.sin(angles)), axis=1)
    if keep_invalid:
        return points
    valid = np.isfinite(ranges) & (ranges >= scan.range_min) & (ranges <= scan.range_max)
    return points[valid]


def decode_laser_scan(msg: Any) -> LaserScanValue:
    try:
        return LaserScanValue(
            numeric_view(msg.ranges, np.float32),
            numeric_view(msg.intensities, np.float32),
            msg.angle_min,
            msg.angle_max,
            msg.angle_increment,
            msg.time_increment,
            msg.scan_time,
            msg.range_min,
            msg.range_max,
        )
    except (AttributeError, TypeError) as error:  # free until raised: a class, a Point()
        raise decode_failure(error, msg, "sensor_msgs/msg/LaserScan") from None


def _checked(value: Any) -> LaserScanValue:
    if not isinstance(value, LaserScanValue):
        raise EncodeError(f"LaserScan: expected LaserScanValue, got {type_name_of(value)}")
    return value


class LaserScanCodec(FieldsCodec):
    """sensor_msgs/LaserScan ↔ ``LaserScanValue``."""

    msg_type = "sensor_msgs/msg/LaserScan"
    lossless = False

    decode = staticmethod(decode_laser_scan)

    def to_fields(self, value: Any) -> dict[str, Any]:
        scan = _checked(value)
        fields: dict[str, Any] = {
            k: check_float32(getattr(scan, k), f"LaserScan.{k}") for k in _GEOMETRY
        }
        fields["ranges"] = np.asarray(
            filled_array(scan.ranges, np.float32, "LaserScan.ranges"), np.float32
        )
        fields["intensities"] = np.asarray(
            filled_array(scan.intensities, np.float32, "LaserScan.intensities"), np.float32
        )
        return fields
