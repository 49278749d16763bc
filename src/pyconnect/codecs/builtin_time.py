"""``builtin_interfaces/Time`` and ``Duration`` ↔ ``RosTime``/``RosDuration`` (sec, nanosec) tuples.

Why not int nanoseconds: a message may carry ``nanosec >= 10**9`` (uint32 allows it), and
``sec * 10**9 + nanosec`` would then fold two different messages into one value. The natural
value is a named ``(sec, nanosec)`` tuple, which keeps both fields exactly (``lossless`` is
True) and still unpacks like a tuple; ``.nanoseconds`` gives the int when that is what you want.
Encode also accepts a plain ``(sec, nanosec)`` pair, or an int of nanoseconds (split with
``divmod``, so ``nanosec`` < 10**9).
"""

from __future__ import annotations

import numbers
from typing import Any, NamedTuple

from pyconnect.codecs.checks import check_int, check_sequence

__all__ = ["DurationCodec", "RosDuration", "RosTime", "TimeCodec"]


class RosTime(NamedTuple):
    """A ``builtin_interfaces/Time``: seconds (int32) and nanoseconds (uint32)."""

    sec: int
    nanosec: int

    @property
    def nanoseconds(self) -> int:
        return self.sec * 1_000_000_000 + self.nanosec

    @classmethod
    def from_nanoseconds(cls, nanoseconds: int) -> RosTime:
        sec, nanosec = divmod(nanoseconds, 1_000_000_000)
        return cls(sec, nanosec)


class RosDuration(NamedTuple):
    """A ``builtin_interfaces/Duration``: seconds (int32) and nanoseconds (uint32)."""

    sec: int
    nanosec: int

    @property
    def nanoseconds(self) -> int:
        return self.sec * 1_000_000_000 + self.nanosec

    @classmethod
    def from_nanoseconds(cls, nanoseconds: int) -> RosDuration:
        sec, nanosec = divmod(nanoseconds, 1_000_000_000)
        return cls(sec, nanosec)


def time_fields(value: Any, path: str) -> dict[str, int]:
    """``{"sec", "nanosec"}`` of a (sec, nanosec) pair or int nanoseconds, range-checked."""
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        sec, nanosec = divmod(int(value), 1_000_000_000)
    else:
        sec, nanosec = check_sequence(value, 2, path, "(sec, nanosec) or int nanoseconds")
    return {
        "sec": check_int(sec, "int32", f"{path}.sec"),
        "nanosec": check_int(nanosec, "uint32", f"{path}.nanosec"),
    }


class TimeCodec:
    """builtin_interfaces/Time ↔ ``RosTime(sec, nanosec)``."""

    msg_type = "builtin_interfaces/msg/Time"
    lossless = True

    def decode(self, msg: Any) -> RosTime:
        return RosTime(msg.sec, msg.nanosec)

    def to_fields(self, value: Any) -> dict[str, int]:
        return time_fields(value, "Time")

    def encode(self, value: Any) -> Any:
        from builtin_interfaces.msg import Time

        return Time(**time_fields(value, "Time"))


class DurationCodec:
    """builtin_interfaces/Duration ↔ ``RosDuration(sec, nanosec)``."""

    msg_type = "builtin_interfaces/msg/Duration"
    lossless = True

    def decode(self, msg: Any) -> RosDuration:
        return RosDuration(msg.sec, msg.nanosec)

    def to_fields(self, value: Any) -> dict[str, int]:
        return time_fields(value, "Duration")

    def encode(self, value: Any) -> Any:
        from builtin_interfaces.msg import Duration

        return Duration(**time_fields(value, "Duration"))
