"""Where an error text fits in a response or result message (``success``/``message`` fields)."""

from __future__ import annotations

from typing import Any

_TEXT_FIELDS = ("message", "error", "error_message", "error_msg", "error_string", "reason")


def text_field(msg_class: type) -> str | None:
    """The first string field that can carry an error text, or None."""
    fields: dict[str, str] = msg_class.get_fields_and_field_types()  # type: ignore[attr-defined]
    for name in _TEXT_FIELDS:
        if fields.get(name) == "string":
            return name
    return None


def error_message(msg_class: type, text: str) -> Any:
    """A default message of ``msg_class`` with ``success=False`` and the text, where it fits."""
    msg = msg_class()
    fields: dict[str, str] = msg_class.get_fields_and_field_types()  # type: ignore[attr-defined]
    if fields.get("success") == "boolean":
        msg.success = False
    name = text_field(msg_class)
    if name is not None:
        setattr(msg, name, text)
    return msg


def error_text_of(msg: Any) -> str:
    """The error text a message carries, or an empty string."""
    name = text_field(type(msg))
    return str(getattr(msg, name)) if name is not None else ""
