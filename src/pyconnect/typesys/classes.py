"""Read the type model from installed rosidl Python classes (``SLOT_TYPES`` and a default instance).

Used for types that have no definition text at hand: the classes carry rosidl's parsed field
types, and a default-constructed instance carries the defaults.
"""

from __future__ import annotations

import importlib
from array import array
from pathlib import Path
from typing import Any

from pyconnect.errors import CodecNotFoundError
from pyconnect.typesys.from_rosidl import field_type_of
from pyconnect.typesys.model import DefaultValue, Field, MessageDef, TypeSet
from pyconnect.typesys.names import class_path


def import_class(full_name: str) -> type:
    """The installed rosidl class of ``full_name``, or ``CodecNotFoundError``."""
    module_name, path = class_path(full_name)
    try:
        target: Any = importlib.import_module(module_name)
    except ImportError as error:
        raise CodecNotFoundError(
            f"{full_name}: no generated codec and its package cannot be imported ({error})"
        ) from None
    for attribute in path.split("."):
        target = getattr(target, attribute, None)
        if target is None:
            raise CodecNotFoundError(f"{full_name}: {module_name} has no {path}")
    if not isinstance(target, type) or not hasattr(target, "SLOT_TYPES"):
        raise CodecNotFoundError(f"{full_name}: {module_name}.{path} is not a message class")
    return target


def _default_of(value: object) -> DefaultValue:
    if isinstance(value, bool | int | float | str):
        return value
    if isinstance(value, bytes):
        return value[0] if len(value) == 1 else None
    if isinstance(value, array):
        return tuple(value.tolist()) or None
    tolist = getattr(value, "tolist", None)
    if callable(tolist):
        items = tolist()
        return tuple(items) if items else None
    if isinstance(value, list) and value and not hasattr(value[0], "SLOT_TYPES"):
        return tuple(v[0] if isinstance(v, bytes) else v for v in value)
    return None


def message_def_from_class(full_name: str, cls: type) -> MessageDef:
    """The IR of an installed class: fields from SLOT_TYPES, defaults from a default instance."""
    package, namespace, name = full_name.split("/")
    names = list(cls.get_fields_and_field_types())  # type: ignore[attr-defined]
    slot_types = cls.SLOT_TYPES  # type: ignore[attr-defined]
    instance = cls()
    origin = Path(f"{package}/{namespace}/{name}")
    fields = tuple(
        Field(n, field_type_of(t, origin, n), _default_of(getattr(instance, "_" + n)))
        for n, t in zip(names, slot_types, strict=True)
    )
    module, path = class_path(full_name)
    return MessageDef(package, namespace, name, fields, python_module=module, python_class=path)  # type: ignore[arg-type]


def type_set_from_classes(full_name: str) -> TypeSet:
    """``full_name`` and every type it nests, read from the installed classes."""
    types = TypeSet()
    pending = [full_name]
    while pending:
        name = pending.pop()
        if name in types.messages:
            continue
        msg = message_def_from_class(name, import_class(name))
        types.messages[name] = msg
        pending.extend(msg.nested_types)
    return types
