"""``Stamped``: a decoded value with the stamp and frame of its message's ``std_msgs/Header``.

The header is found by duck typing, so rclpy messages and the wire codecs' views both work: the
``header`` field, else the first field whose declared type is ``std_msgs/Header``, else the
message itself when it is a Header (it has ``stamp`` and ``frame_id``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Generic, TypeVar

from pyconnect.codecs.base import Codec
from pyconnect.errors import DecodeError, EncodeError, type_name_of

T = TypeVar("T")

_HEADER_FIELD: dict[type, str | None] = {}


@dataclass(frozen=True)
class Stamped(Generic[T]):
    """A value plus its header: ``stamp_ns`` is nanoseconds since the epoch of the stamp."""

    value: T
    stamp_ns: int
    frame_id: str = ""


def _is_header(candidate: Any) -> bool:
    stamp = getattr(candidate, "stamp", None)
    return (
        stamp is not None
        and hasattr(stamp, "sec")
        and hasattr(stamp, "nanosec")
        and hasattr(candidate, "frame_id")
    )


def _header_field(cls: type) -> str | None:
    if cls in _HEADER_FIELD:
        return _HEADER_FIELD[cls]
    found: str | None = None
    field_types = getattr(cls, "get_fields_and_field_types", None)
    if callable(field_types):
        for name, type_name in field_types().items():
            if type_name in ("std_msgs/Header", "std_msgs/msg/Header"):
                found = name
                break
    _HEADER_FIELD[cls] = found
    return found


def header_of(msg: Any) -> Any:
    """The ``std_msgs/Header`` of ``msg``, or None when it has none."""
    header = getattr(msg, "header", None)
    if header is not None and _is_header(header):
        return header
    name = _header_field(type(msg))
    if name is not None:
        return getattr(msg, name)
    if _is_header(msg):
        return msg
    return None


def decode_stamped(codec: Codec, msg: Any) -> Stamped[Any]:
    """Decode ``msg`` and keep its header; types without a header raise ``DecodeError``."""
    header = header_of(msg)
    if header is None:
        raise DecodeError(f"{codec.msg_type}: has no std_msgs/Header, so it cannot be Stamped")
    stamp = header.stamp
    return Stamped(codec.decode(msg), stamp.sec * 1_000_000_000 + stamp.nanosec, header.frame_id)


def encode_stamped(codec: Codec, stamped: Stamped[Any]) -> Any:
    """Encode ``stamped.value`` and write its stamp and frame into the message header."""
    from pyconnect.codecs.field_checks import check_str  # numpy: not on plain lookups' path

    # rclpy's setter takes any str; its C conversion would cut the frame at a NUL.
    check_str(stamped.frame_id, None, "Stamped.frame_id")
    msg = codec.encode(stamped.value)
    header = header_of(msg)
    if header is None:
        raise EncodeError(f"{codec.msg_type}: has no std_msgs/Header, so it cannot take a Stamped")
    stamp = _time_fields(stamped.stamp_ns)
    header.stamp.sec = stamp["sec"]
    header.stamp.nanosec = stamp["nanosec"]
    header.frame_id = stamped.frame_id
    return msg


def stamped_header(stamped: Stamped[Any]) -> dict[str, Any]:
    """The lossless dict of the header a ``Stamped`` value's message carries (checked)."""
    from pyconnect.codecs.field_checks import check_str

    check_str(stamped.frame_id, None, "Stamped.frame_id")
    return {"stamp": _time_fields(stamped.stamp_ns), "frame_id": stamped.frame_id}


def _time_fields(stamp_ns: Any) -> dict[str, int]:
    """The header's sec/nanosec of ``stamp_ns``, checked: rclpy's setters check nothing, so a
    stamp past 2038 wrapped to 1901 on the wire and a float failed inside serialisation."""
    import numbers

    from pyconnect.codecs.builtin_time import time_fields

    if not isinstance(stamp_ns, numbers.Integral) or isinstance(stamp_ns, bool):
        raise EncodeError(
            f"Stamped.stamp_ns: expected int nanoseconds, got {type_name_of(stamp_ns)}"
        )
    return time_fields(int(stamp_ns), "Stamped.stamp_ns")
