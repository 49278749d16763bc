"""Parse .msg/.srv/.action/.idl text into the type model, with rosidl's own parsers.

``rosidl_adapter`` turns .msg/.srv/.action text into IDL and ``rosidl_parser`` parses IDL;
``from_rosidl`` maps the result onto the model. The rosidl objects are kept for hashing.
"""

from __future__ import annotations

import contextlib
import functools
import io
import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pyconnect.typesys.errors import DefinitionError
from pyconnect.typesys.from_rosidl import action_def, message_def, service_def
from pyconnect.typesys.model import ActionDef, MessageDef, ServiceDef
from pyconnect.typesys.packages import (
    INTERFACE_NAMESPACES,
    INTERFACE_SUFFIXES,
    InstalledPackage,
    folder_interface_files,
    folder_package_name,
    interface_namespace,
    read_text_file,
)

# -- parsing ----------------------------------------------------------------------------------
_ADAPTER_TEMPLATES = {".msg": ("msg", "msg.idl.em"), ".srv": ("srv", "srv.idl.em"),
                      ".action": ("action", "action.idl.em")}  # fmt: skip


def _parse_with_adapter(package: str, path: Path, text: str) -> Any:
    from rosidl_adapter import parser as adapter

    parse = {
        ".msg": adapter.parse_message_string,
        ".srv": adapter.parse_service_string,
        ".action": adapter.parse_action_string,
    }[path.suffix]
    # rosidl_adapter prints its own multi-line report; ours is the one-line DefinitionError.
    with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
        return parse(package, path.stem, text)


def _idl_from_interface_text(package: str, path: Path, text: str) -> str:
    """Convert .msg/.srv/.action text to IDL text with rosidl_adapter (as rosidl's build does)."""
    from rosidl_adapter.resource import evaluate_template

    try:
        spec = _parse_with_adapter(package, path, text)
    except Exception as error:
        line = _failing_line(package, path, text)
        message = _one_line(error)
        # rosidl reads an unknown lower-case type as a badly named message type.
        unknown = re.match(r"'([a-z]\w*)' is an invalid message name", message)
        if unknown:
            message = f"unknown type {unknown.group(1)!r}"
        raise DefinitionError(message, path=path, line=line) from None
    _reject_ros1_builtins(path, text)
    key, template = _ADAPTER_TEMPLATES[path.suffix]
    data = {"pkg_name": package, "relative_input_file": f"{key}/{path.name}", key: spec}
    try:
        # rosidl's template prints its own report and calls sys.exit(1) on what it cannot map.
        with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
            content: str = evaluate_template(template, data)
    except (Exception, SystemExit) as error:
        reason = "it exited" if isinstance(error, SystemExit) else _one_line(error)
        raise DefinitionError(f"rosidl cannot convert it to IDL ({reason})", path=path) from None
    return content


# ROS 1 builtins that rosidl_adapter parses but has no IDL type for.
_ROS1_BUILTINS = frozenset({"time", "duration"})


def _reject_ros1_builtins(path: Path, text: str) -> None:
    """Refuse a field of ROS 1's ``time``/``duration`` (ROS 2 spells them builtin_interfaces/Time
    and Duration): rosidl_adapter parses them and only its IDL template fails, by exiting."""
    for number, raw in enumerate(text.splitlines(), start=1):
        tokens = raw.split("#", 1)[0].split()
        base = re.split(r"[\[<]", tokens[0], maxsplit=1)[0] if tokens else ""
        if base in _ROS1_BUILTINS:
            raise DefinitionError(f"unknown type {base!r}", path=path, line=number)


def _one_line(error: BaseException) -> str:
    text = " ".join(str(error).split()) or type(error).__name__
    return text


def _failing_line(package: str, path: Path, text: str) -> int | None:
    """The first line whose addition makes the definition unparsable (rosidl does not say)."""
    if path.suffix != ".msg":
        return None
    lines = text.splitlines()
    for end in range(1, len(lines) + 1):
        try:
            _parse_with_adapter(package, path, "\n".join(lines[:end]))
        except Exception:
            return end
    return None


def _parse_idl(text: str, origin: Path) -> Any:
    from rosidl_parser.parser import parse_idl_string

    try:
        return parse_idl_string(text)
    except Exception as error:
        raise DefinitionError(_one_line(error), path=origin) from None


@dataclass
class ParsedInterfaces:
    """What parsing some files gave: IR objects plus rosidl's own objects, for hashing."""

    messages: list[MessageDef] = field(default_factory=list)
    services: list[ServiceDef] = field(default_factory=list)
    actions: list[ActionDef] = field(default_factory=list)
    rosidl_elements: list[Any] = field(default_factory=list)
    origins: dict[str, Path] = field(default_factory=dict)


def parse_interface_text(package: str, path: Path, text: str, into: ParsedInterfaces) -> None:
    """Parse one .msg/.srv/.action/.idl text (``path`` names it in errors) into ``into``."""
    if path.suffix == ".idl":
        idl_text = text
    elif path.suffix in INTERFACE_SUFFIXES:
        idl_text = _idl_from_interface_text(package, path, text)
    else:
        raise DefinitionError("not an interface file (.msg, .srv, .action or .idl)", path=path)
    content = _parse_idl(idl_text, path)
    try:
        _add_elements(package, path, content.elements, into)
    except DefinitionError as error:
        if error.line is not None or error.member is None:
            raise
        line = line_declaring(text, error.member, idl=path.suffix == ".idl")
        raise DefinitionError(error.detail, path=path, line=line) from None


def line_declaring(text: str, member: str, *, idl: bool) -> int | None:
    """The first line that declares the field or constant ``member`` (None if none is found)."""
    name = re.escape(member)
    # .msg: `type name [default]` or `type NAME=value`; IDL: `type name;`, `const type NAME = v;`
    pattern = re.compile(rf"\b{name}\s*[=;]" if idl else rf"^\s*\S+\s+{name}(\s|=|$)")
    for number, line in enumerate(text.splitlines(), start=1):
        if pattern.search(line.split("//" if idl else "#", 1)[0]):
            return number
    return None


def _add_elements(package: str, path: Path, elements: list[Any], into: ParsedInterfaces) -> None:
    from rosidl_parser import definition as d

    for element in elements:
        if isinstance(element, d.Message | d.Service | d.Action):
            _check_modules(element, path)
        if isinstance(element, d.Message):
            namespace = element.structure.namespaced_type.namespaces[1]
            name = element.structure.namespaced_type.name
            python = (f"{package}.{namespace}", name)
            msg = message_def(element.structure, element.constants, path, python)
            into.messages.append(msg)
            into.origins[msg.full_name] = path
        elif isinstance(element, d.Service):
            srv = service_def(element, path, f"{package}.srv", element.namespaced_type.name)
            into.services.append(srv)
            for msg in srv.messages:
                into.origins[msg.full_name] = path
        elif isinstance(element, d.Action):
            act = action_def(element, path, f"{package}.action")
            into.actions.append(act)
            for msg in act.messages:
                into.origins[msg.full_name] = path
        else:
            continue
        into.rosidl_elements.append(element)


def _check_modules(element: Any, path: Path) -> None:
    """A type is declared in ``module <package> { module msg|srv|action``, as rosidl needs."""
    from rosidl_parser import definition as d

    if isinstance(element, d.Message):
        named = element.structure.namespaced_type
    else:
        named = element.namespaced_type
    if len(named.namespaces) != 2 or named.namespaces[1] not in INTERFACE_NAMESPACES:
        raise DefinitionError(
            f"declares {named.name} outside a `module <package> {{ module msg|srv|action {{ }} }}`",
            path=path,
        )


def parse_installed_package(package: InstalledPackage, into: ParsedInterfaces) -> None:
    parsed = _parse_installed(package)
    into.messages += parsed.messages
    into.services += parsed.services
    into.actions += parsed.actions
    into.rosidl_elements += parsed.rosidl_elements
    into.origins.update(parsed.origins)


@functools.cache
def _parse_installed(package: InstalledPackage) -> ParsedInterfaces:
    # Parsing IDL with lark is slow (tens of ms a file) and installed files do not change
    # while a process runs, so each package is parsed once.
    parsed = ParsedInterfaces()
    for relative in package.idl_files:
        path = package.share / relative
        parse_interface_text(package.name, path, read_text_file(path), parsed)
    return parsed


def parse_folder(folder: Path, into: ParsedInterfaces) -> str:
    """Parse a bare folder of interface files; returns its package name."""
    if not folder.is_dir():
        raise DefinitionError("no such folder", path=folder)
    package = folder_package_name(folder)
    files = folder_interface_files(folder)
    if not files:
        raise DefinitionError("no .msg, .srv, .action or .idl files found", path=folder)
    for path in files:
        parse_interface_text(package, path, read_text_file(path), into)
        if path.suffix == ".idl":
            _check_idl_place(package, path, into)
    return package


def _check_idl_place(package: str, path: Path, parsed: ParsedInterfaces) -> None:
    """An .idl file of a folder declares its types in ``<package>::<namespace>`` and is named
    after one of them, as rosidl's generators (which name their output by file) require."""
    namespace = interface_namespace(path)
    names = [name for name, origin in parsed.origins.items() if origin == path]
    for full_name in names:
        pkg, ns, _name = full_name.split("/")
        if (pkg, ns) != (package, namespace):
            raise DefinitionError(
                f"declares {pkg}::{ns}, expected module {package}::{namespace} "
                "(the folder's package and namespace)",
                path=path,
            )
    stem = path.stem
    if not any(n.split("/")[2] == stem or n.split("/")[2].startswith(stem + "_") for n in names):
        raise DefinitionError(f"declares no type named {stem} (the file's name)", path=path)


def iter_messages(parsed: ParsedInterfaces) -> Iterator[MessageDef]:
    yield from parsed.messages
    for srv in parsed.services:
        yield from srv.messages
    for act in parsed.actions:
        yield from act.messages
