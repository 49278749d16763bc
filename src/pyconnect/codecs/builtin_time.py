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
from collections.abc import Callable
from typing import Any, ClassVar, NamedTuple, TypeVar

from pyconnect.codecs.base import FieldsCodec, checked_reader, decode_failure
from pyconnect.codecs.field_checks import check_kind_int, check_tuple

__all__ = ["DurationCodec", "RosDuration", "RosTime", "TimeCodec"]


_T = TypeVar("_T", bound="_SecNanosec")
_FIELDS = ("sec", "nanosec")
_new_tuple = tuple.__new__


class _SecNanosec(NamedTuple):
    """Seconds (int32) and nanoseconds (uint32), the two fields of Time and Duration."""

    sec: int
    nanosec: int

    @property
    def nanoseconds(self) -> int:
        return self.sec * 1_000_000_000 + self.nanosec

    @classmethod
    def from_nanoseconds(cls: type[_T], nanoseconds: int) -> _T:
        sec, nanosec = divmod(nanoseconds, 1_000_000_000)
        return cls(sec, nanosec)


class RosTime(_SecNanosec):
    """A ``builtin_interfaces/Time``: seconds (int32) and nanoseconds (uint32)."""

    __slots__ = ()


class RosDuration(_SecNanosec):
    """A ``builtin_interfaces/Duration``: seconds (int32) and nanoseconds (uint32)."""

    __slots__ = ()


def time_fields(value: Any, path: str) -> dict[str, int]:
    """``{"sec", "nanosec"}`` of a (sec, nanosec) pair or int nanoseconds, range-checked."""
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        sec, nanosec = divmod(int(value), 1_000_000_000)
    else:
        sec, nanosec = check_tuple(value, 2, "(sec, nanosec) or int nanoseconds", path)
    return {
        "sec": check_kind_int(sec, "int32", f"{path}.sec"),
        "nanosec": check_kind_int(nanosec, "uint32", f"{path}.nanosec"),
    }


class _SecNanosecCodec(FieldsCodec):
    """A ``builtin_interfaces`` (sec, nanosec) type ↔ its named tuple."""

    name: ClassVar[str]
    value_type: ClassVar[type[_SecNanosec]]
    lossless = True

    def __init__(self) -> None:
        self._readers: dict[type, Callable[[Any], Any]] = {}

    def decode(self, msg: Any) -> _SecNanosec:
        reader = self._readers.get(type(msg))
        if reader is None:  # once per class: a class, a Duration for a Time is refused here
            reader = self._readers[type(msg)] = checked_reader(msg, self.msg_type, _FIELDS)
        # The reader's (sec, nanosec) pair is the tuple itself: no NamedTuple __new__ frame.
        try:
            value: _SecNanosec = _new_tuple(self.value_type, reader(msg))
        except AttributeError as error:  # free until raised: a stand-in lacking a field
            raise decode_failure(error, msg, self.msg_type) from None
        return value

    def to_fields(self, value: Any) -> dict[str, int]:
        return time_fields(value, self.name)


class TimeCodec(_SecNanosecCodec):
    """builtin_interfaces/Time ↔ ``RosTime(sec, nanosec)``."""

    msg_type = "builtin_interfaces/msg/Time"
    name = "Time"
    value_type = RosTime


class DurationCodec(_SecNanosecCodec):
    """builtin_interfaces/Duration ↔ ``RosDuration(sec, nanosec)``."""

    msg_type = "builtin_interfaces/msg/Duration"
    name = "Duration"
    value_type = RosDuration
