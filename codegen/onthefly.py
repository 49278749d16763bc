"""Dict codecs generated at run time for installed message classes that ``generated/`` lacks.

The IR is read from the class itself (rosidl keeps the parsed field types in ``SLOT_TYPES``),
rendered with the same template as ``codecgen build``, compiled once and cached. The source is
registered with ``linecache`` so that tracebacks through it show the real lines.
"""

from __future__ import annotations

import importlib
import linecache
import threading
from array import array
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from codegen.introspect import DefinitionError, _field_type
from codegen.ir import DefaultValue, Field, MessageDef, TypeSet
from codegen.render import render_self_contained_dict_codecs

_ACTION_PARTS = {
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
_SERVICE_PARTS = ("Request", "Response", "Event")

_lock = threading.Lock()
_compiled: dict[str, tuple[type, Callable[[Any], Any], Callable[[Mapping[str, Any]], Any]]] = {}


def class_path(full_name: str) -> tuple[str, str]:
    """(module, dotted attribute path) of the rosidl Python class of a message type."""
    package, namespace, name = full_name.split("/")
    module = f"{package}.{namespace}"
    if namespace == "srv":
        for part in _SERVICE_PARTS:
            if name.endswith("_" + part):
                return module, f"{name[: -len(part) - 1]}.{part}"
    if namespace == "action":
        for suffix, path in _ACTION_PARTS.items():
            if name.endswith("_" + suffix):
                return module, f"{name[: -len(suffix) - 1]}.{path}"
    return module, name


def import_class(full_name: str) -> type:
    """The installed rosidl class of ``full_name``, or ``CodecNotFoundError``."""
    from pyconnect.errors import CodecNotFoundError

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
        Field(n, _field_type(t, origin), _default_of(getattr(instance, "_" + n)))
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


def compile_dict_codec(
    full_name: str,
) -> tuple[type, Callable[[Any], Any], Callable[[Mapping[str, Any]], Any]]:
    """(class, to_dict, from_dict) for ``full_name``, generated and compiled once per process."""
    cached = _compiled.get(full_name)
    if cached is not None:
        return cached
    with _lock:
        cached = _compiled.get(full_name)
        if cached is not None:
            return cached
        try:
            types = type_set_from_classes(full_name)
        except DefinitionError as error:
            from pyconnect.errors import CodecNotFoundError

            raise CodecNotFoundError(f"{full_name}: {error}") from None
        source = render_self_contained_dict_codecs(types.closure(full_name), types)
        filename = f"<codecgen on-the-fly dict codecs for {full_name}>"
        linecache.cache[filename] = (len(source), None, source.splitlines(True), filename)
        namespace: dict[str, Any] = {
            "__name__": f"pyconnect_onthefly.{full_name.replace('/', '.')}"
        }
        exec(compile(source, filename, "exec"), namespace)
        for name, (cls, to_dict, from_dict, _fields) in namespace["DICT_CODECS"].items():
            _compiled.setdefault(name, (cls, to_dict, from_dict))
        return _compiled[full_name]
