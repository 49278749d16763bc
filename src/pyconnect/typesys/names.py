"""ROS type names: parse every way users name a type, and the names of service and action parts.

Users name a type by class, instance, ``"pkg/msg/Name"`` or ``"pkg/Name"``. Services and
actions have implicit message types (``SetBool_Request``, ``Fibonacci_SendGoal_Request``...):
the rules for those names, and for the rosidl Python class that holds each part, live here.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from pyconnect.errors import CodecNotFoundError

_NAME = re.compile(r"^([A-Za-z][A-Za-z0-9_]*)/(?:(msg|srv|action)/)?([A-Za-z][A-Za-z0-9_]*)$")


@dataclass(frozen=True)
class TypeName:
    """A parsed ROS interface name. ``namespace`` is None when the user left it out."""

    package: str
    namespace: str | None
    name: str

    def full(self, namespace: str | None = None) -> str:
        return f"{self.package}/{namespace or self.namespace or 'msg'}/{self.name}"


def parse_type_name(type_ref: object) -> TypeName:
    """Parse a class, a message instance or a string into a ``TypeName``.

    Classes and instances are named by the module rosidl generated them in
    (``std_srvs.srv._set_bool.SetBool_Request`` -> ``std_srvs/srv/SetBool_Request``).
    """
    if isinstance(type_ref, str):
        match = _NAME.match(type_ref.strip())
        if match is None:
            raise CodecNotFoundError(
                f"{type_ref!r} is not a ROS type name: expected 'pkg/msg/Name' or 'pkg/Name'"
            )
        package, namespace, name = match.groups()
        return TypeName(package, namespace, name)
    cls = type_ref if isinstance(type_ref, type) else type(type_ref)
    module = getattr(cls, "__module__", "") or ""
    parts = module.split(".")
    if len(parts) >= 2 and parts[1] in ("msg", "srv", "action"):
        return TypeName(parts[0], parts[1], cls.__name__)
    raise CodecNotFoundError(f"{cls.__qualname__} (module {module!r}) is not a ROS interface class")


def full_type_name(type_ref: object) -> str:
    """The canonical ``pkg/ns/Name`` of any type reference; ``pkg/Name`` means a message."""
    return parse_type_name(type_ref).full()


# -- service and action parts ------------------------------------------------------------------
SERVICE_PARTS = ("Request", "Response", "Event")
# Action part suffix -> the dotted path of its class under the action's class.
ACTION_PARTS: dict[str, str] = {
    "Goal": "Goal",
    "Result": "Result",
    "Feedback": "Feedback",
    "FeedbackMessage": "Impl.FeedbackMessage",
    "SendGoal_Request": "Impl.SendGoalService.Request",
    "SendGoal_Response": "Impl.SendGoalService.Response",
    "SendGoal_Event": "Impl.SendGoalService.Event",
    "GetResult_Request": "Impl.GetResultService.Request",
    "GetResult_Response": "Impl.GetResultService.Response",
    "GetResult_Event": "Impl.GetResultService.Event",
}


def is_interface_name(name: str) -> bool:
    """True for a service or action's own name: CamelCase never has the ``_`` its parts have."""
    return "_" not in name


def split_part(namespace: str, name: str) -> tuple[str, str] | None:
    """(interface name, part suffix) of a service or action part's name, else None.

    ``split_part("action", "Fibonacci_SendGoal_Request") == ("Fibonacci", "SendGoal_Request")``
    """
    suffixes = (
        SERVICE_PARTS
        if namespace == "srv"
        else tuple(ACTION_PARTS)
        if namespace == "action"
        else ()
    )
    for suffix in sorted(suffixes, key=len, reverse=True):
        if name.endswith("_" + suffix) and len(name) > len(suffix) + 1:
            return name[: -len(suffix) - 1], suffix
    return None


def class_path(full_name: str) -> tuple[str, str]:
    """(module, dotted attribute path) of the rosidl Python class of a message type."""
    package, namespace, name = full_name.split("/")
    module = f"{package}.{namespace}"
    part = split_part(namespace, name)
    if part is None:
        return module, name
    interface, suffix = part
    return module, f"{interface}.{ACTION_PARTS[suffix] if namespace == 'action' else suffix}"
