"""CDR wire codecs: CDR bytes <-> natural values or lossless dicts, no rclpy (docs/design.md §3).

``decode(data, "sensor_msgs/msg/Image")`` turns a serialized message (``bytes``, ``bytearray``,
``memoryview`` or ``mmap``; little- or big-endian XCDR1 with its 4-byte encapsulation header)
into the natural value the registry's codec gives, or into the lossless dict. ``encode`` goes
back to little-endian CDR. The registry (``default_registry`` unless ``registry=``) finds each
type's ``WireCodec``: from ``generated/`` (``codecgen build``), else compiled on the fly from
installed definitions or from a definition text (bags).

What decoding gives:

- Lossless dicts are exactly what ``pyconnect.codecs.to_dict`` gives for the same live message:
  numeric arrays and sequences are lists, ``uint8``/``byte``/``char`` ones ``bytes``, strings
  ``str`` (one value per type, whatever the source).
- Views (``decode_view``) are light objects with ``__slots__`` named as the ROS fields; their
  numeric and byte arrays are numpy arrays that view the input buffer (read-only for ``bytes``;
  they keep the buffer alive, and an ``mmap`` cannot close while they exist). Natural codecs
  read them as they read rclpy messages, so an Image decodes to a zero-copy ndarray.
- Up to 3 bytes after the message are accepted (Fast DDS pads the payload to 4 bytes; rosbags
  accepts the same), and so are the unwritten bytes up to Fast DDS's size estimate, which
  ``rclpy.serialization.serialize_message`` returns (the estimate aligns empty sequences of
  8-byte values). More, fewer or malformed bytes raise ``DecodeError`` naming the field path.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from pyconnect.codecs.registry import Registry, default_registry
from pyconnect.codecs.wire_codec import WireCodec

__all__ = [
    "WireCodec",
    "decode",
    "encode",
    "from_dict",
    "register_definition",
    "to_dict",
    "wire_codec",
]


def wire_codec(
    msg_type: str,
    *,
    definition: str | None = None,
    encoding: str = "ros2msg",
    registry: Registry | None = None,
) -> WireCodec:
    """The wire codec of ``msg_type`` ("pkg/msg/Name" or "pkg/Name").

    Without ``definition``: the generated codec, else one compiled from the installed
    definitions (or the one ``register_definition`` made). With ``definition`` (a bag's
    ``ros2msg``/``ros2idl`` text, or ``.srv`` text for service events): compiled from that text,
    cached by the text's digest and shared by every text of the same RIHS01 hash.
    """
    registry = registry or default_registry
    return registry.wire_codec(msg_type, definition=definition, encoding=encoding)


def register_definition(
    msg_type: str, text: str, *, encoding: str = "ros2msg", registry: Registry | None = None
) -> WireCodec:
    """Compile ``msg_type`` from a definition text and make it the codec its name finds."""
    return (registry or default_registry).register_definition(msg_type, text, encoding=encoding)


def decode(
    data: Any, msg_type: str, *, natural: bool = True, registry: Registry | None = None
) -> Any:
    """CDR bytes -> the natural value of ``msg_type`` (or its lossless dict)."""
    return (registry or default_registry).wire_codec(msg_type).decode(data, natural=natural)


def encode(value: Any, msg_type: str, *, registry: Registry | None = None) -> bytes:
    """The natural value of ``msg_type`` -> little-endian CDR bytes with the header.

    For a type without a natural codec the natural value is its lossless dict; for the others
    (Image, Twist, JointState, ...) a lossless dict goes through ``from_dict``."""
    return (registry or default_registry).wire_codec(msg_type).encode(value)


def to_dict(data: Any, msg_type: str, *, registry: Registry | None = None) -> dict[str, Any]:
    """CDR bytes -> the lossless dict of ``msg_type``."""
    return (registry or default_registry).wire_codec(msg_type).to_dict(data)


def from_dict(d: Mapping[str, Any], msg_type: str, *, registry: Registry | None = None) -> bytes:
    """A lossless dict -> little-endian CDR bytes with the header."""
    return (registry or default_registry).wire_codec(msg_type).from_dict(d)
