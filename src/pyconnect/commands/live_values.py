"""Live values as text: natural values in one line, images as a summary, JSON, and parsing VALUE.

``echo_value(msg)`` decodes an rclpy message with the codec registry and gives what ``topic
echo`` prints: an image as ``Image(shape=(480, 640, 3), dtype=uint8, encoding=rgb8,
mean=127.512)``, anything else as its natural value with big arrays summarised. ``--json``
prints ``json_value`` of the same: images as ``{"shape", "dtype", "encoding", "mean"}``,
arrays as lists, bytes as lists of ints. ``message_from_text`` builds a message from a YAML or
JSON VALUE: a dict of the message's fields, or the type's natural value.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import yaml

from pyconnect import codecs
from pyconnect.commands.graph import CommandFailed
from pyconnect.commands.value_text import format_value

__all__ = ["ImageSummary", "echo_value", "json_value", "message_from_text", "select_field"]

_IMAGE_TYPES = {"Image", "CompressedImage"}


class ImageSummary:
    """An image in one line: shape, dtype, encoding and mean pixel value."""

    def __init__(self, array: np.ndarray[Any, Any], encoding: str) -> None:
        self.shape = tuple(int(n) for n in array.shape)
        self.dtype = str(array.dtype)
        self.encoding = encoding
        self.mean = float(array.mean()) if array.size else math.nan

    def as_dict(self) -> dict[str, Any]:
        return {
            "shape": list(self.shape),
            "dtype": self.dtype,
            "encoding": self.encoding,
            "mean": round(self.mean, 3),
        }

    def __repr__(self) -> str:
        return (
            f"Image(shape={self.shape}, dtype={self.dtype}, encoding={self.encoding}, "
            f"mean={self.mean:.3f})"
        )


def select_field(msg: Any, field: str | None) -> Any:
    """``msg.a.b`` for ``--field a.b`` (ros2cli's syntax); the message itself for None."""
    if not field:
        return msg
    value = msg
    for part in field.split("."):
        if not hasattr(value, "get_fields_and_field_types") or not hasattr(value, part):
            raise CommandFailed(f"--field {field}: no field {part!r} in {type(value).__name__}")
        value = getattr(value, part)
    return value


def _is_message(value: Any) -> bool:
    return hasattr(value, "get_fields_and_field_types")


def echo_value(value: Any) -> Any:
    """The natural value of a message (an image as ``ImageSummary``), or the plain field."""
    if not _is_message(value):
        return value
    decoded = codecs.decode(value)
    if type(value).__name__ in _IMAGE_TYPES and isinstance(decoded, np.ndarray):
        encoding = str(getattr(value, "encoding", None) or getattr(value, "format", ""))
        return ImageSummary(decoded, encoding)
    return decoded


def echo_line(value: Any) -> str:
    """One line for ``topic echo``."""
    if isinstance(value, ImageSummary):
        return repr(value)
    return format_value(value)


def json_value(value: Any) -> Any:
    """``value`` as plain JSON data (tuples and arrays become lists)."""
    if isinstance(value, ImageSummary):
        return value.as_dict()
    if isinstance(value, np.ndarray):
        if value.dtype.names is not None:
            return [json_value(row) for row in value.tolist()]
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, bytes | bytearray | memoryview):
        return list(bytes(value))
    if isinstance(value, dict):
        return {str(key): json_value(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [json_value(item) for item in value]
    if _is_message(value):
        return json_value(codecs.to_dict(value))
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return value


def _tuples(value: Any) -> Any:
    if isinstance(value, list):
        return tuple(_tuples(item) for item in value)
    if isinstance(value, dict):
        return {key: _tuples(item) for key, item in value.items()}
    return value


def message_from_text(text: str, msg_class: type) -> Any:
    """A message of ``msg_class`` from YAML/JSON: its fields as a dict, or its natural value."""
    try:
        value = yaml.safe_load(text) if text.strip() else {}
    except yaml.YAMLError as error:
        raise CommandFailed(f"VALUE is not YAML or JSON: {' '.join(str(error).split())}") from None
    fields = set(msg_class.get_fields_and_field_types())  # type: ignore[attr-defined]
    if isinstance(value, dict) and set(value) <= fields:
        try:
            return codecs.from_dict(value, msg_class)
        except Exception as error:
            raise CommandFailed(str(error)) from None
    try:
        return codecs.encode(_tuples(value), msg_class)
    except Exception as error:
        raise CommandFailed(str(error)) from None
