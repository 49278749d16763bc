"""Turn every way users name a ROS type (class, instance, "pkg/msg/Name", "pkg/Name") into one."""

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
