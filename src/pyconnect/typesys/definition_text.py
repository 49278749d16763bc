"""Definition text as bags store it, read back into the type model (``resolve_definition``).

The layouts are those rosbag2 writes (``ros2msg``: the main type's text, then one block per
dependency headed by a line of ``=`` and ``MSG: pkg/Name``; ``ros2idl``: every block headed by
``IDL: pkg/msg/Name``; a service event: a first block headed ``SRV: pkg/srv/Name``, or the raw
``.srv`` text), as ``pyconnect.typesys.installed_definition_text`` writes them for installed
types. A service or action part may be written in ``.msg`` form, and its blocks and field types
named ``pkg/srv/Name`` or ``pkg/action/Name`` (``pyconnect.typesys.part_standins``).
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from pathlib import Path
from typing import NamedTuple

from pyconnect.typesys.errors import DefinitionError
from pyconnect.typesys.loading import build_type_set, reject_recursive_types
from pyconnect.typesys.model import MessageDef, TypeSet
from pyconnect.typesys.names import split_part
from pyconnect.typesys.packages import installed_packages
from pyconnect.typesys.parse import (
    ParsedInterfaces,
    iter_messages,
    parse_installed_package,
    parse_interface_text,
)
from pyconnect.typesys.part_standins import PartStandIns

__all__ = [
    "parse_definition",
    "resolve_definition",
    "split_type",
]

_SEPARATOR = re.compile(r"^={10,}[ \t]*$", re.MULTILINE)
_BLOCK_HEADER = re.compile(
    r"^\s*(MSG|SRV|IDL):\s*([A-Za-z][A-Za-z0-9_]*)/(?:(msg|srv|action)/)?([A-Za-z][A-Za-z0-9_]*)\s*$"
)


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
    # rosbag2 stores the .msg/.idl files verbatim: one written on Windows (CRLF) or old Mac
    # (CR) keeps its line ends, which the separator and header patterns (``$``) and rosidl's
    # parser do not take as ends of lines.
    text = text.replace("\r\n", "\n").replace("\r", "\n")
    blocks = _SEPARATOR.split(text)
    _refuse_oversized(msg_type, blocks)
    stand_ins = PartStandIns(text)
    # ros2idl, and rosbag2 Jazzy's layout of a service event (`SRV: pkg/srv/Name`), head the
    # main type's block like the others: the text starts with a separator (or, from some
    # writers, with the header itself).
    main = blocks[0]
    main_headed = _Block.header(main) is not None
    headed = [_Block.read(msg_type, block, encoding) for block in blocks[0 if main_headed else 1 :]]
    try:
        if not main_headed and encoding == "ros2idl" and main.strip():
            raise DefinitionError(f"{msg_type}: an IDL block lacks its 'IDL: pkg/msg/Name'")
        if not main_headed and encoding == "ros2msg" and (main.strip() or len(blocks) == 1):
            _parse_main(package, namespace, name, main, parsed, stand_ins=stand_ins)
        _parse_blocks([b for b in headed if b is not None], parsed, stand_ins)
    except DefinitionError as error:
        raise stand_ins.real_error(error) from None
    stand_ins.rename(parsed)
    return parsed


class _Block(NamedTuple):
    """A block after a separator: its header ``KIND: package/[namespace/]name`` and its text."""

    kind: str  # MSG, SRV or IDL
    package: str
    namespace: str  # "" when the header leaves it out
    name: str
    body: str

    @staticmethod
    def header(block: str) -> re.Match[str] | None:
        return _BLOCK_HEADER.match(block.strip("\n").split("\n", 1)[0])

    @classmethod
    def read(cls, msg_type: str, block: str, encoding: str) -> _Block | None:
        """The block, None if it is blank."""
        lines = block.strip("\n").split("\n", 1)
        if not lines[0].strip():
            return None
        match = cls.header(block)
        if match is None:
            if encoding == "ros2idl":
                raise DefinitionError(f"{msg_type}: an IDL block lacks its 'IDL: pkg/msg/Name'")
            raise DefinitionError(f"{msg_type}: a definition block lacks its 'MSG: pkg/Name' line")
        kind, package, namespace, name = match.groups()
        return cls(kind, package, namespace or "", name, lines[1] if len(lines) > 1 else "")


def _parse_blocks(blocks: list[_Block], into: ParsedInterfaces, stand_ins: PartStandIns) -> None:
    """Parse the blocks headed ``MSG:``, ``SRV:`` or ``IDL:``, each as the file kind it names."""
    idl_types = {(b.package, b.name) for b in blocks if b.kind == "IDL"}
    idl_done: set[tuple[str, str]] = set()
    for kind, package, namespace, name, body in blocks:
        if kind == "IDL":
            # rosbag2 names a type `pkg/Name` or `pkg/msg/Name` by where it found it: it can
            # write the same file twice.
            if (package, name) not in idl_done:
                idl_done.add((package, name))
                path = Path(f"{namespace or 'msg'}/{name}.idl")
                parse_interface_text(package, path, body, into)
        elif kind == "SRV":
            if namespace not in ("", "srv"):
                raise DefinitionError(f"SRV: {package}/{namespace}/{name} is not a service")
            parse_interface_text(package, Path(f"srv/{name}.srv"), body, into)
        elif not body.strip() and (package, name) in idl_types:
            # rosbag2 Jazzy, finding no .msg for a service's dependency, leaves its `MSG:` line
            # without a text and writes the dependency again as IDL.
            continue
        elif namespace in ("srv", "action"):
            part = stand_ins.name(package, namespace, name)
            parse_interface_text(package, Path(f"msg/{part}.msg"), stand_ins.respell(body), into)
        else:
            parse_interface_text(package, Path(f"msg/{name}.msg"), stand_ins.respell(body), into)


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


def _parse_main(
    package: str,
    namespace: str,
    name: str,
    text: str,
    into: ParsedInterfaces,
    *,
    stand_ins: PartStandIns,
) -> None:
    has_parts = re.search(r"^---\s*$", text, re.MULTILINE) is not None
    if namespace in ("srv", "action") and has_parts:
        part = split_part(namespace, name)
        base = part[0] if part is not None else name
        parse_interface_text(package, Path(f"{namespace}/{base}.{namespace}"), text, into)
        return
    if namespace in ("srv", "action"):
        # A service or action part stored as plain .msg text.
        name = stand_ins.name(package, namespace, name)
    parse_interface_text(package, Path(f"msg/{name}.msg"), stand_ins.respell(text), into)


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
