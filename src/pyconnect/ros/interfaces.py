"""Find the rclpy class of an agent's ``data_interface`` (a class or ``"pkg/msg/Name"``)."""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import importlib
from typing import Any

from pyconnect.errors import PyconnectError
from pyconnect.typesys.names import parse_type_name


def interface_class(data_interface: object, *, kind: str) -> Any:
    """The class of a message (``kind='msg'``), service (``'srv'``) or action (``'action'``).

    Strings may leave the namespace out (``"std_msgs/String"``): ``kind`` fills it in.
    """
    if isinstance(data_interface, type):
        cls = data_interface
    elif isinstance(data_interface, str):
        parsed = parse_type_name(data_interface)
        namespace = parsed.namespace or kind
        try:
            module = importlib.import_module(f"{parsed.package}.{namespace}")
            cls = getattr(module, parsed.name)
        except (ImportError, AttributeError) as error:
            raise PyconnectError(
                f"{parsed.full(namespace)}: no such interface is installed ({error})"
            ) from error
    else:
        raise PyconnectError(
            f"data_interface: expected an interface class or 'pkg/{kind}/Name', "
            f"got {type(data_interface).__name__}"
        )
    found = _kind_of(cls)
    if found != kind:
        raise PyconnectError(
            f"{interface_name(cls)}: expected a {_KIND_WORDS[kind]} type, got a "
            f"{_KIND_WORDS.get(found, 'non-ROS')} type"
        )
    return cls


_KIND_WORDS = {"msg": "message", "srv": "service", "action": "action"}


def _kind_of(cls: type) -> str:
    if hasattr(cls, "Goal") and hasattr(cls, "Result") and hasattr(cls, "Feedback"):
        return "action"
    if hasattr(cls, "Request") and hasattr(cls, "Response"):
        return "srv"
    if hasattr(cls, "get_fields_and_field_types"):
        return "msg"
    return "unknown"


def interface_name(cls: Any) -> str:
    """``"pkg/ns/Name"`` of an interface class (the name users see in errors and logs)."""
    try:
        return parse_type_name(cls).full()
    except PyconnectError:
        return getattr(cls, "__qualname__", repr(cls))


def header_field(msg_class: type) -> bool:
    """True when the message type starts with a ``std_msgs/Header header`` field."""
    fields: dict[str, str] = msg_class.get_fields_and_field_types()  # type: ignore[attr-defined]
    return fields.get("header") == "std_msgs/Header"
