"""Definition text as bags store it, both ways: write it for installed types, parse it back.

The ``ros2msg`` layout rosbag2 (Jazzy) writes: the main type's ``.msg`` text first; then, for
every type it depends on (each text's dependencies in sorted order, depth first, each once), a
newline, a line of 80 ``=``, a line ``MSG: pkg/Name`` and that type's ``.msg`` text. A type
that has, or nests one that has, no ``.msg`` file is written as ``ros2idl``: one block per
type, the main type's first, each headed by the separator and ``IDL: pkg/msg/Name``, the
dependencies being the files an ``.idl`` includes. A service event type (``pkg/srv/Name_Event``)
is written as the raw ``.srv`` text, as rosbag2 Jazzy does; an action part
(``pkg/action/Name_FeedbackMessage``...) in its ``.msg`` form (see ``_action_part_text``).
"""

from __future__ import annotations

import functools
import re
from collections.abc import Iterable
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


def interface_file(package: str, namespace: str, name: str, extension: str = "") -> Path:
    """The installed ``.msg``/``.srv``/``.action`` file of a type (``CodecNotFoundError``);
    ``extension="idl"`` asks for its ``.idl`` file instead."""
    share = installed_share_dirs().get(package)
    if share is None:
        raise CodecNotFoundError(
            f"{package}/{namespace}/{name}: package {package!r} is not installed"
        )
    path = share / namespace / f"{name}.{extension or namespace}"
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


# `#include "pkg/msg/Name.idl"` (or <...>): what an .idl file depends on, as rosbag2 finds it.
_IDL_INCLUDE = re.compile(r'^#include\s+["<]([A-Za-z0-9_/]+)\.idl[">]', re.MULTILINE)


def definition_encoding(text: str) -> str:
    """``ros2idl`` for a text laid out as ``installed_definition`` writes IDL, else ``ros2msg``."""
    return "ros2idl" if text.startswith(f"{DEFINITION_SEPARATOR}\nIDL: ") else "ros2msg"


@functools.lru_cache(maxsize=512)
def installed_definition(msg_type: str) -> str:
    """The definition text rosbag2 stores for an installed message type (``ros2msg``, or
    ``ros2idl`` when a type involved has only an ``.idl`` file: ``definition_encoding`` tells),
    a service event (the raw ``.srv`` text) or an action part (see ``_action_part_text``)."""
    parsed = parse_type_name(msg_type)
    namespace = parsed.namespace or "msg"
    if namespace == "srv" and parsed.name.endswith("_Event"):
        service = parsed.name[: -len("_Event")]
        return interface_file(parsed.package, "srv", service).read_text(encoding="utf-8")
    if namespace == "action":
        return _action_part_text(parsed.package, parsed.name)
    if namespace != "msg":
        raise CodecNotFoundError(
            f"{msg_type}: only messages, service events and action parts have a definition text"
        )
    try:
        return _msg_text_with_dependencies(parsed.package, _msg_text(parsed.package, parsed.name))
    except CodecNotFoundError as no_msg:
        # As rosbag2 does: a type that has (or nests one that has) no .msg file is stored as IDL.
        try:
            return _idl_text_with_dependencies(f"{parsed.package}/msg/{parsed.name}")
        except CodecNotFoundError:
            raise no_msg from None


def _msg_text(package: str, name: str) -> str:
    return interface_file(package, "msg", name).read_text(encoding="utf-8")


def _msg_text_with_dependencies(package: str, main: str, seen: set[str] | None = None) -> str:
    """rosbag2 Jazzy's layout: after a text, each type it depends on that was not written yet,
    in sorted order (a std::set), as a newline, the separator, ``MSG: pkg/Name`` and its text,
    itself followed by its own dependencies (depth first)."""
    seen = set() if seen is None else seen
    definition = main
    for dependency in sorted(dependencies_of(main, package)):
        if dependency in seen:
            continue
        seen.add(dependency)
        dep_package, dep_name = dependency.split("/")
        text = _msg_text(dep_package, dep_name)
        definition += f"\n{DEFINITION_SEPARATOR}\nMSG: {dependency}\n"
        definition += _msg_text_with_dependencies(dep_package, text, seen)
    return definition


def _idl_text_with_dependencies(full_name: str) -> str:
    """rosbag2's ``ros2idl`` layout: every block, the main type's first, is headed by the
    separator and ``IDL: pkg/msg/Name``; the dependencies are the files it ``#include``s."""
    seen: set[str] = set()

    def with_includes(type_name: str) -> str:
        package, *_, name = type_name.split("/")
        text = interface_file(package, "msg", name, "idl").read_text(encoding="utf-8")
        for dependency in sorted(set(_IDL_INCLUDE.findall(text))):
            if dependency in seen:
                continue
            seen.add(dependency)
            text += f"\n{DEFINITION_SEPARATOR}\nIDL: {dependency}\n" + with_includes(dependency)
        return text

    return f"{DEFINITION_SEPARATOR}\nIDL: {full_name}\n" + with_includes(full_name)


# The implicit message types of an action, in .msg form (``{I}`` is the action's name).
_ACTION_PART_TEXTS = {
    "FeedbackMessage": "unique_identifier_msgs/UUID goal_id\n{I}_Feedback feedback\n",
    "SendGoal_Request": "unique_identifier_msgs/UUID goal_id\n{I}_Goal goal\n",
    "SendGoal_Response": "bool accepted\nbuiltin_interfaces/Time stamp\n",
    "GetResult_Request": "unique_identifier_msgs/UUID goal_id\n",
    "GetResult_Response": "int8 status\n{I}_Result result\n",
    "SendGoal_Event": "service_msgs/ServiceEventInfo info\n"
    "{I}_SendGoal_Request[<=1] request\n{I}_SendGoal_Response[<=1] response\n",
    "GetResult_Event": "service_msgs/ServiceEventInfo info\n"
    "{I}_GetResult_Request[<=1] request\n{I}_GetResult_Response[<=1] response\n",
}
_ACTION_SECTIONS = ("Goal", "Result", "Feedback")


def _action_part_text(package: str, name: str) -> str:
    """``ros2msg`` text of an action part (``pkg/action/Fibonacci_FeedbackMessage``...).

    rosbag2 Jazzy stores none for these (encoding ``unknown``, which rosbags cannot open);
    this text is the part's fields in .msg form with its dependencies as ``MSG:`` blocks, the
    action's own parts named ``pkg/action/Name`` and every other message type qualified with
    its package, so that a reader resolving names by the enclosing block's namespace (rosbags)
    finds each one.
    """
    part = split_part("action", name)
    if part is None:
        raise CodecNotFoundError(f"{package}/action/{name}: not a part of an action")
    interface = part[0]
    action_text = interface_file(package, "action", interface).read_text(encoding="utf-8")
    sections = re.split(r"^---[ \t]*\r?$\n?", action_text, flags=re.MULTILINE)
    texts = {suffix: text for suffix, text in zip(_ACTION_SECTIONS, sections, strict=False)}
    texts.update({s: t.format(I=interface) for s, t in _ACTION_PART_TEXTS.items()})
    own = {f"{package}/{interface}_{suffix}": suffix for suffix in texts}
    seen: set[str] = set()

    def with_dependencies(text: str) -> str:
        definition = _qualified(text, package, own)
        for dependency in sorted(dependencies_of(text, package)):
            if dependency in seen:
                continue
            seen.add(dependency)
            if dependency in own:
                header = f"{package}/action/{dependency.split('/')[1]}"
                definition += f"\n{DEFINITION_SEPARATOR}\nMSG: {header}\n"
                definition += with_dependencies(texts[own[dependency]])
            else:
                dep_package, dep_name = dependency.split("/")
                definition += f"\n{DEFINITION_SEPARATOR}\nMSG: {dependency}\n"
                dep_text = _msg_text(dep_package, dep_name)
                definition += _msg_text_with_dependencies(dep_package, dep_text, seen)
        return definition

    suffix = part[1]
    if suffix not in texts:
        raise CodecNotFoundError(f"{package}/action/{name}: no such part of an action")
    return with_dependencies(texts[suffix])


_FIELD_TYPE = re.compile(r"^(\s*)([A-Za-z][A-Za-z0-9_/]*)(?=[\s\[<])")


def _qualified(text: str, package: str, own: dict[str, str]) -> str:
    """``text`` with each message field type spelled in full: ``pkg/Name``, or
    ``pkg/action/Name`` for the action's own parts (a bare ``Name`` in an .action file means
    ``pkg/msg/Name``; a reader of a ``pkg/action/...`` block would look in ``action``)."""
    lines = []
    for line in text.splitlines(keepends=True):
        dependency = dependencies_of(line, package)
        match = _FIELD_TYPE.match(line)
        if not (dependency and match):
            lines.append(line)
            continue
        full = dependency[0]
        if full in own:
            full = f"{package}/action/{full.split('/')[1]}"
        lines.append(match.group(1) + full + line[match.end(2) :])
    return "".join(lines)


# -- reading definition text ------------------------------------------------------------------
def split_type(msg_type: str) -> tuple[str, str, str]:
    parts = msg_type.strip().split("/")
    if len(parts) == 2:
        return parts[0], "msg", parts[1]
    if len(parts) == 3 and parts[1] in ("msg", "srv", "action"):
        return parts[0], parts[1], parts[2]
    raise DefinitionError(f"{msg_type!r} is not a ROS type name ('pkg/msg/Name' or 'pkg/Name')")


MAX_TYPES = 256
"""Types (blocks) one definition text may hold."""
MAX_DECLARATIONS = 1000
"""Field and constant lines one type of a definition text may hold."""
MAX_NESTING = 64
"""How deep the types of a definition text may nest."""


def parse_definition(msg_type: str, text: str, encoding: str) -> ParsedInterfaces:
    """Parse a bag's definition text of ``msg_type`` into IR (one block per type)."""
    if encoding not in ("ros2msg", "ros2idl"):
        raise DefinitionError(f"unsupported definition encoding {encoding!r} (ros2msg or ros2idl)")
    package, namespace, name = split_type(msg_type)
    parsed = ParsedInterfaces()
    blocks = _SEPARATOR.split(text)
    _refuse_oversized(msg_type, blocks)
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


def _refuse_oversized(msg_type: str, blocks: list[str]) -> None:
    """Refuse a text far beyond any real message before rosidl parses it: its parser takes about
    2 ms a declaration, so a bag whose stored text declares 20,000 fields stalled a read for a
    minute (and a compile of 300 nested types failed in Python's parser)."""
    if len(blocks) > MAX_TYPES:
        raise DefinitionError(
            f"{msg_type}: the text defines {len(blocks)} types (at most {MAX_TYPES})"
        )
    for block in blocks:
        lines = sum(1 for line in block.splitlines() if line.strip() and line.lstrip()[0] != "#")
        if lines > MAX_DECLARATIONS:
            raise DefinitionError(
                f"{msg_type}: a type of the text has {lines} lines of declarations "
                f"(at most {MAX_DECLARATIONS})"
            )


def _refuse_deep_nesting(full_name: str, types: Iterable[MessageDef]) -> None:
    """Refuse types nested deeper than ``MAX_NESTING`` (the text is known free of cycles)."""
    nested = {m.full_name: m.nested_types for m in types}
    depths: dict[str, int] = {}  # how many levels of types each one holds, itself included

    def depth(name: str, level: int) -> int:
        # ``level``: where ``name`` sits; checked on the way down, so the recursion stays short.
        found = depths.get(name)
        if found is None and level <= MAX_NESTING:
            children = nested.get(name, ())
            found = depths[name] = 1 + max((depth(c, level + 1) for c in children), default=0)
        if found is None or level + found - 1 > MAX_NESTING:
            raise DefinitionError(f"{full_name}: types nested more than {MAX_NESTING} deep")
        return found

    for name in nested:
        depth(name, 1)


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
    _refuse_deep_nesting(full_name, iter_messages(parsed))
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
