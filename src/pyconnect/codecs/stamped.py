"""``Stamped``: a decoded value with the stamp and frame of its message's ``std_msgs/Header``."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Generic, TypeVar

from pyconnect.codecs.base import Codec
from pyconnect.errors import DecodeError, EncodeError

T = TypeVar("T")


@dataclass(frozen=True)
class Stamped(Generic[T]):
    """A value plus its header: ``stamp_ns`` is nanoseconds since the epoch of the stamp."""

    value: T
    stamp_ns: int
    frame_id: str = ""


def _header_of(msg: Any) -> Any:
    header = getattr(msg, "header", None)
    if header is None or type(header).__name__ != "Header":
        return None
    return header


def decode_stamped(codec: Codec, msg: Any) -> Stamped[Any]:
    """Decode ``msg`` and keep its header; types without a header raise ``DecodeError``."""
    header = _header_of(msg)
    if header is None:
        raise DecodeError(f"{codec.msg_type}: has no std_msgs/Header, so it cannot be Stamped")
    stamp = header.stamp
    return Stamped(codec.decode(msg), stamp.sec * 1_000_000_000 + stamp.nanosec, header.frame_id)


def encode_stamped(codec: Codec, stamped: Stamped[Any]) -> Any:
    """Encode ``stamped.value`` and write its stamp and frame into the message header."""
    msg = codec.encode(stamped.value)
    header = _header_of(msg)
    if header is None:
        raise EncodeError(f"{codec.msg_type}: has no std_msgs/Header, so it cannot take a Stamped")
    sec, nanosec = divmod(stamped.stamp_ns, 1_000_000_000)
    header.stamp.sec = sec
    header.stamp.nanosec = nanosec
    header.frame_id = stamped.frame_id
    return msg
