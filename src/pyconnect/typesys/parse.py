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
    INTERFACE_SUFFIXES,
    InstalledPackage,
    folder_interface_files,
    folder_package_name,
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
    key, template = _ADAPTER_TEMPLATES[path.suffix]
    data = {"pkg_name": package, "relative_input_file": f"{key}/{path.name}", key: spec}
    content: str = evaluate_template(template, data)
    return content


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
    from rosidl_parser import definition as d

    if path.suffix == ".idl":
        idl_text = text
    elif path.suffix in INTERFACE_SUFFIXES:
        idl_text = _idl_from_interface_text(package, path, text)
    else:
        raise DefinitionError("not an interface file (.msg, .srv, .action or .idl)", path=path)
    content = _parse_idl(idl_text, path)
    for element in content.elements:
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
        parse_interface_text(package.name, path, path.read_text(encoding="utf-8"), parsed)
    return parsed


def parse_folder(folder: Path, into: ParsedInterfaces) -> str:
    """Parse a bare folder of interface files; returns its package name."""
    if not folder.is_dir():
        raise DefinitionError("no such folder", path=folder)
    package = folder_package_name(folder)
    files = folder_interface_files(folder)
    if not files:
        raise DefinitionError("no .msg, .srv or .action files found", path=folder)
    for path in files:
        parse_interface_text(package, path, path.read_text(encoding="utf-8"), into)
    return package


def iter_messages(parsed: ParsedInterfaces) -> Iterator[MessageDef]:
    yield from parsed.messages
    for srv in parsed.services:
        yield from srv.messages
    for act in parsed.actions:
        yield from act.messages
