"""Live values as text: natural values in one line, images as a summary, JSON.

``echo_value(msg)`` decodes an rclpy message with the codec registry and gives what ``topic
echo`` prints: an image as ``Image(shape=(480, 640, 3), dtype=uint8, encoding=rgb8,
mean=127.512)``, anything else as its natural value with big arrays summarised. ``--json``
prints ``json_value`` of the same: images as ``{"shape", "dtype", "encoding", "mean"}``,
arrays as lists, bytes as lists of ints, dataclasses as dicts. ``message_from_text`` (from
``value_input``) builds a message from a YAML or JSON VALUE.
"""

from __future__ import annotations

import json
import math
from typing import Any, TextIO

import numpy as np

from pyconnect import codecs
from pyconnect.commands.graph import PROGRAM, CommandFailed
from pyconnect.commands.value_input import message_from_text
from pyconnect.commands.value_text import ImageSummary, format_value, plain_value

__all__ = [
    "ImageSummary",
    "echo_json",
    "echo_value",
    "json_value",
    "message_from_text",
    "select_field",
    "shown_line",
    "shown_text",
]

IMAGE_TYPES = {"Image", "CompressedImage"}


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
    if type(value).__name__ in IMAGE_TYPES and isinstance(decoded, np.ndarray):
        encoding = str(getattr(value, "encoding", None) or getattr(value, "format", ""))
        return ImageSummary(decoded, encoding)
    return decoded


def echo_line(value: Any) -> str:
    """One line for ``topic echo``."""
    if isinstance(value, ImageSummary):
        return repr(value)
    return format_value(value)


def _live_plain(value: Any) -> Any:
    """What ``plain_value`` leaves to the live tools: summaries, messages, non-finite floats."""
    if isinstance(value, ImageSummary):
        return value.as_dict()
    if _is_message(value):
        return codecs.to_dict(value)
    if isinstance(value, float | np.floating) and not math.isfinite(value):
        return str(float(value))  # JSON has no NaN or Infinity
    return value


def json_value(value: Any) -> Any:
    """``value`` as plain JSON data: tuples, arrays and dataclasses become lists and dicts."""
    return plain_value(value, other=_live_plain)


def _unknown_as_text(value: Any) -> str:
    try:
        return repr(value)
    except Exception:  # a broken __repr__ must not end the echo either
        return f"<{type(value).__name__}>"


def echo_json(value: Any) -> str:
    """One JSON line of ``value``; a value of no known kind is written as its repr, never an
    error (a user codec may return anything)."""
    return json.dumps(json_value(value), default=_unknown_as_text)


def shown_text(value: Any, *, as_json: bool = False) -> tuple[str | None, str | None]:
    """What the live tools print of a message or field, and the problem when its natural value
    could not be made (the text is then its plain fields, or None when even those fail).

    One undecodable message (a short image frame, a CompressedImage that is not jpeg) must not
    end an echo that would print the good ones after it, as ``ros2 topic echo`` goes on."""
    try:
        shown = echo_value(value)
        return (echo_json(shown) if as_json else echo_line(shown)), None
    except Exception as error:  # any codec, the user's included
        problem = " ".join(str(error).split()) or type(error).__name__
    try:
        plain = codecs.to_dict(value) if _is_message(value) else value
        return (echo_json(plain) if as_json else format_value(plain)), problem
    except Exception:
        return None, problem


def shown_line(value: Any, err: TextIO) -> str:
    """``shown_text`` for a value printed beside the real work (what ``pub`` publishes, a
    service's request and response): a warning on ``err`` when it is shown by its fields."""
    text, problem = shown_text(value)
    name = type(value).__name__
    if problem is not None:
        said = "shown as its fields" if text is not None else "not shown"
        print(f"{PROGRAM}: warning: cannot decode the {name} ({said}): {problem}", file=err)
    return text if text is not None else f"<{name}>"
