"""Definition text as bags store it, both ways: write it for installed types, parse it back.

The ``ros2msg`` layout rosbag2 writes: the main type's ``.msg`` text first; then, for every type
it depends on (depth first, each once), a line of 80 ``=``, a line ``MSG: pkg/Name`` and that
type's ``.msg`` text. A service event type (``pkg/srv/Name_Event``) is written as the raw
``.srv`` text, as rosbag2 Jazzy does. ``ros2idl`` has one block per type headed
``IDL: pkg/msg/Name``.
"""

from __future__ import annotations

import functools
import re
from dataclasses import replace
from pathlib import Path

from pyconnect.errors import CodecNotFoundError
from pyconnect.typesys.errors import DefinitionError
from pyconnect.typesys.loading import build_type_set, reject_recursive_types
from pyconnect.typesys.model import MessageDef, TypeSet
from pyconnect.typesys.names import parse_type_name, split_part
from pyconnect.typesys.packages import installed_packages, installed_share_dirs
from pyconnect.typesys.parse import (
    ParsedInterfaces,
    iter_messages,
    parse_installed_package,
    parse_interface_text,
)
from pyconnect.typesys.primitives import MSG_BUILTIN_NAMES

__all__ = [
    "DEFINITION_SEPARATOR",
    "dependencies_of",
    "installed_definition",
    "interface_file",
    "parse_definition",
    "resolve_definition",
    "split_type",
]

DEFINITION_SEPARATOR = "=" * 80
_SEPARATOR = re.compile(r"^={10,}[ \t]*$", re.MULTILINE)
_BLOCK_HEADER = re.compile(
    r"^\s*(MSG|IDL):\s*([A-Za-z][A-Za-z0-9_]*)/(?:(msg|srv|action)/)?([A-Za-z][A-Za-z0-9_]*)\s*$"
)


def interface_file(package: str, namespace: str, name: str) -> Path:
    """The installed ``.msg``/``.srv``/``.action`` file of a type (``CodecNotFoundError``)."""
    share = installed_share_dirs().get(package)
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
    if base in MSG_BUILTIN_NAMES:
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


# -- reading definition text ------------------------------------------------------------------
def split_type(msg_type: str) -> tuple[str, str, str]:
    parts = msg_type.strip().split("/")
    if len(parts) == 2:
        return parts[0], "msg", parts[1]
    if len(parts) == 3 and parts[1] in ("msg", "srv", "action"):
        return parts[0], parts[1], parts[2]
    raise DefinitionError(f"{msg_type!r} is not a ROS type name ('pkg/msg/Name' or 'pkg/Name')")


def parse_definition(msg_type: str, text: str, encoding: str) -> ParsedInterfaces:
    """Parse a bag's definition text of ``msg_type`` into IR (one block per type)."""
    if encoding not in ("ros2msg", "ros2idl"):
        raise DefinitionError(f"unsupported definition encoding {encoding!r} (ros2msg or ros2idl)")
    package, namespace, name = split_type(msg_type)
    parsed = ParsedInterfaces()
    blocks = _SEPARATOR.split(text)
    main, rest = blocks[0], blocks[1:]
    if encoding == "ros2idl":
        # The main type is a block like the others, headed `IDL: pkg/msg/Name`.
        for block in blocks:
            lines = block.strip("\n").split("\n", 1)
            match = _BLOCK_HEADER.match(lines[0]) if lines else None
            if match is None:
                if block.strip():
                    raise DefinitionError(f"{msg_type}: an IDL block lacks its 'IDL: pkg/msg/Name'")
                continue
            pkg, ns, nm = match.group(2), match.group(3) or "msg", match.group(4)
            body = lines[1] if len(lines) > 1 else ""
            parse_interface_text(pkg, Path(f"{ns}/{nm}.idl"), body, parsed)
        return parsed
    _parse_main(package, namespace, name, main, parsed)
    for block in rest:
        lines = block.strip("\n").split("\n", 1)
        if not lines or not lines[0].strip():
            continue
        match = _BLOCK_HEADER.match(lines[0])
        if match is None:
            raise DefinitionError(f"{msg_type}: a definition block lacks its 'MSG: pkg/Name' line")
        pkg, nm = match.group(2), match.group(4)
        body = lines[1] if len(lines) > 1 else ""
        parse_interface_text(pkg, Path(f"msg/{nm}.msg"), body, parsed)
    return parsed


def _parse_main(package: str, namespace: str, name: str, text: str, into: ParsedInterfaces) -> None:
    has_parts = re.search(r"^---\s*$", text, re.MULTILINE) is not None
    if namespace in ("srv", "action") and has_parts:
        part = split_part(namespace, name)
        base = part[0] if part is not None else name
        parse_interface_text(package, Path(f"{namespace}/{base}.{namespace}"), text, into)
        return
    parse_interface_text(package, Path(f"msg/{name}.msg"), text, into)
    if namespace != "msg":
        # A service or action part stored as plain .msg text: move it to its namespace.
        into.messages[-1] = replace(into.messages[-1], namespace=namespace)  # type: ignore[arg-type]


def resolve_definition(msg_type: str, text: str, encoding: str) -> tuple[MessageDef, TypeSet]:
    """The type model of ``msg_type`` as the text defines it; dependencies may come from installed
    packages (the types the text defines win)."""
    package, namespace, name = split_type(msg_type)
    full_name = f"{package}/{namespace}/{name}"
    parsed = parse_definition(msg_type, text, encoding)
    defined = {m.full_name for m in iter_messages(parsed)}
    if full_name not in defined:
        raise DefinitionError(f"{full_name}: the definition text does not define it")
    installed = installed_packages()
    tried: set[str] = set()
    while True:
        known = {m.full_name for m in iter_messages(parsed)}
        missing = sorted({n for m in iter_messages(parsed) for n in m.nested_types} - known)
        if not missing:
            break
        packages = sorted({n.split("/")[0] for n in missing} - tried)
        if not any(pkg in installed for pkg in packages):
            raise DefinitionError(
                f"{full_name}: unknown type {missing[0]} (not in the text, not installed)"
            )
        for pkg in packages:
            tried.add(pkg)
            if pkg in installed:
                extra = ParsedInterfaces()
                parse_installed_package(installed[pkg], extra)
                _merge_installed(parsed, extra, defined)
    # Before the hashing below, whose failures are forgiven: a recursive text never decodes.
    reject_recursive_types(parsed)
    types = TypeSet()
    try:
        hashed: TypeSet | None = build_type_set(parsed)[0]
    except (DefinitionError, KeyError, ValueError):
        hashed = None  # rosidl cannot hash some texts (old definitions): decode them unhashed
    for msg in iter_messages(parsed):
        types.messages[msg.full_name] = hashed.get(msg.full_name) if hashed is not None else msg
    return types.get(full_name), types


def _merge_installed(parsed: ParsedInterfaces, extra: ParsedInterfaces, defined: set[str]) -> None:
    """Add an installed package's types, except those the text defines (the text wins)."""
    from rosidl_parser import definition as d

    parsed.messages += [m for m in extra.messages if m.full_name not in defined]
    parsed.services += [
        s for s in extra.services if not {m.full_name for m in s.messages} & defined
    ]
    parsed.actions += [a for a in extra.actions if not {m.full_name for m in a.messages} & defined]
    for element in extra.rosidl_elements:
        if isinstance(element, d.Message):
            name = "/".join(element.structure.namespaced_type.namespaced_name())
            if name in defined:
                continue
        parsed.rosidl_elements.append(element)
