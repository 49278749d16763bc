"""The ``ros2msg`` definition text of an installed type, in the layout rosbag2 writes to bags.

The main type's ``.msg`` text comes first; then, for every type it depends on (depth first, each
once), a line of 80 ``=``, a line ``MSG: pkg/Name`` and that type's ``.msg`` text. A service
event type (``pkg/srv/Name_Event``) is written as the raw ``.srv`` text, as rosbag2 Jazzy does.
"""

from __future__ import annotations

import functools
from pathlib import Path

from pyconnect.codecs.type_names import parse_type_name
from pyconnect.errors import CodecNotFoundError

__all__ = ["DEFINITION_SEPARATOR", "dependencies_of", "installed_definition", "interface_file"]

DEFINITION_SEPARATOR = "=" * 80
_PRIMITIVES = frozenset(
    {
        "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16",
        "int32", "uint32", "int64", "uint64", "string", "wstring",
    }
)  # fmt: skip


@functools.lru_cache(maxsize=1)
def _share_dirs() -> dict[str, Path]:
    from codegen.introspect import installed_packages

    return {name: package.share for name, package in installed_packages().items()}


def interface_file(package: str, namespace: str, name: str) -> Path:
    """The installed ``.msg``/``.srv``/``.action`` file of a type (``CodecNotFoundError``)."""
    share = _share_dirs().get(package)
    if share is None:
        raise CodecNotFoundError(
            f"{package}/{namespace}/{name}: package {package!r} is not installed"
        )
    path = share / namespace / f"{name}.{namespace}"
    if not path.is_file():
        raise CodecNotFoundError(f"{package}/{namespace}/{name}: no {path.name} in {share}")
    return path


def _base_type(field_type: str, package: str) -> str | None:
    """``pkg/Name`` of a field type that is a message, None for primitives."""
    base = field_type.split("[", 1)[0]
    base = base.split("<=", 1)[0]
    if base in _PRIMITIVES:
        return None
    if "/" not in base:
        return f"{package}/{base}"
    parts = base.split("/")
    return f"{parts[0]}/{parts[-1]}"


def dependencies_of(text: str, package: str) -> list[str]:
    """The message types (``pkg/Name``) that fields of a ``.msg``/``.srv`` text refer to."""
    found: list[str] = []
    for raw in text.splitlines():
        line = raw.strip()
        if not line or line.startswith("#") or line == "---":
            continue
        tokens = line.split(None, 2)
        if len(tokens) < 2 or "=" in tokens[1] or (len(tokens) > 2 and tokens[2].startswith("=")):
            continue  # a constant: its type is always primitive
        dependency = _base_type(tokens[0], package)
        if dependency is not None and dependency not in found:
            found.append(dependency)
    return found


@functools.lru_cache(maxsize=512)
def installed_definition(msg_type: str) -> str:
    """The rosbag2 ``ros2msg`` definition text of an installed message or service event type."""
    parsed = parse_type_name(msg_type)
    namespace = parsed.namespace or "msg"
    if namespace == "srv" and parsed.name.endswith("_Event"):
        service = parsed.name[: -len("_Event")]
        return interface_file(parsed.package, "srv", service).read_text(encoding="utf-8")
    if namespace != "msg":
        raise CodecNotFoundError(
            f"{msg_type}: only messages and service events have a ros2msg definition"
        )
    main = interface_file(parsed.package, "msg", parsed.name).read_text(encoding="utf-8")
    definition = main
    seen = {f"{parsed.package}/{parsed.name}"}
    pending = list(reversed(dependencies_of(main, parsed.package)))
    while pending:
        dependency = pending.pop()
        if dependency in seen:
            continue
        seen.add(dependency)
        package, name = dependency.split("/")
        text = interface_file(package, "msg", name).read_text(encoding="utf-8")
        if definition and not definition.endswith("\n"):
            definition += "\n"
        definition += f"{DEFINITION_SEPARATOR}\nMSG: {dependency}\n{text}"
        pending.extend(reversed(dependencies_of(text, package)))
    return definition
