"""Parse .msg/.srv/.action/.idl text into the type model, with rosidl's own parsers.

``rosidl_adapter`` turns .msg/.srv/.action text into IDL and ``rosidl_parser`` parses IDL;
``from_rosidl`` maps the result onto the model. The rosidl objects are kept for hashing.
Without rosidl's parsers installed, reading any definition is one ``DefinitionError`` saying
what to install (``require_rosidl``).
"""

from __future__ import annotations

import contextlib
import functools
import importlib
import io
import re
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from pyconnect.typesys.errors import DefinitionError
from pyconnect.typesys.fault_search import line_at_fault
from pyconnect.typesys.from_rosidl import MemberError, action_def, message_def, service_def
from pyconnect.typesys.member_lines import line_declaring, rendered_member_at, sections
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

__all__ = [
    "ROSIDL_INSTALL",
    "ParsedInterfaces",
    "iter_messages",
    "line_declaring",
    "parse_folder",
    "parse_installed_package",
    "parse_interface_text",
    "require_rosidl",
]

# -- parsing ----------------------------------------------------------------------------------
# rosidl's parsers and its type-hash generator (pyconnect.typesys.hashing): dependencies of
# pyconnect-ros where their wheels exist (x86_64 Linux), also brought by the `ros` extra or a
# sourced ROS install.
_ROSIDL_MODULES = ("rosidl_adapter.parser", "rosidl_adapter.resource", "rosidl_parser.parser",
                   "rosidl_parser.definition", "rosidl_generator_type_description")  # fmt: skip
ROSIDL_INSTALL = "pip install 'pyconnect-ros[ros]' or source a ROS 2 Jazzy install"
_ADAPTER_TEMPLATES = {".msg": ("msg", "msg.idl.em"), ".srv": ("srv", "srv.idl.em"),
                      ".action": ("action", "action.idl.em")}  # fmt: skip
# What converting .msg/.srv/.action text does in turn: parse it, render it as IDL, parse that.
_Stage = Literal["parse", "render", "idl"]


class _ConversionFailed(Exception):
    """rosidl's build cannot turn a parsed definition into IDL text; ``str()`` says why."""


@contextlib.contextmanager
def _quiet(stderr: io.StringIO | None = None) -> Iterator[None]:
    # rosidl_adapter prints its own multi-line reports; ours is the one-line DefinitionError.
    out = io.StringIO()
    with contextlib.redirect_stderr(stderr or out), contextlib.redirect_stdout(out):
        yield


def require_rosidl() -> None:
    """Raise ``DefinitionError`` naming what to install when rosidl's parsers are missing.

    Checked before parsing: a parse failure is otherwise reported as a fault of the definition,
    and the search for its line would import the missing module again, outside any handler.
    """
    for name in _ROSIDL_MODULES:
        try:
            importlib.import_module(name)
        except ModuleNotFoundError as error:
            raise DefinitionError(
                f"reading interface definitions needs rosidl's parsers ({error}): {ROSIDL_INSTALL}"
            ) from None


def _parse_with_adapter(package: str, path: Path, text: str) -> Any:
    from rosidl_adapter import parser as adapter

    parse = {
        ".msg": adapter.parse_message_string,
        ".srv": adapter.parse_service_string,
        ".action": adapter.parse_action_string,
    }[path.suffix]
    with _quiet():
        return parse(package, path.stem, text)


def _parse_interface(package: str, path: Path, text: str) -> Any:
    """Parse .msg/.srv/.action text as rosidl's build does: rosidl_adapter converts it to IDL,
    which rosidl_parser parses."""
    try:
        spec = _parse_with_adapter(package, path, text)
    except Exception as error:
        line = _failing_line(package, path, text, upto="parse")
        message = _one_line(error)
        # rosidl reads an unknown lower-case type as a badly named message type.
        # (Not the file's own name: msg/lower_case.msg is a badly named type, as rosidl says.)
        unknown = re.match(r"'([a-z]\w*)' is an invalid message name", message)
        if unknown and unknown.group(1) != path.stem:
            message = f"unknown type {unknown.group(1)!r}"
        raise DefinitionError(message, path=path, line=line) from None
    _reject_ros1_builtins(path, text)
    key, template = _ADAPTER_TEMPLATES[path.suffix]
    data = {"pkg_name": package, "relative_input_file": f"{key}/{path.name}", key: spec}
    try:
        idl_text = _render_idl(template, data)
    except _ConversionFailed as failure:
        line = _failing_line(package, path, text, upto="render")
        message = f"rosidl cannot convert it to IDL ({failure})"
        raise DefinitionError(message, path=path, line=line) from None
    try:
        return _parse_idl_text(idl_text)
    except Exception as error:
        # e.g. a default ending in a backslash, which escapes the literal's closing quote
        line = _line_lark_stopped_at(package, path, text, idl_text, error)
        if line is None:
            line = _failing_line(package, path, text, upto="idl")
        # lark's report places the fault in IDL text the user never sees, then lists (in no
        # fixed order) the tokens it expected; the snippet it quotes is the useful part.
        reason = re.sub(r",? at line \d+ col \d+", "", _one_line(error)).split(" Expected ")[0]
        message = f"rosidl cannot parse the IDL it converts it to ({reason})"
        raise DefinitionError(message, path=path, line=line) from None


def _render_idl(template: str, data: dict[str, Any]) -> str:
    """The IDL text rosidl's build would parse for ``data``; raises _ConversionFailed."""
    from rosidl_adapter.resource import evaluate_template

    complaint = io.StringIO()
    try:
        # rosidl's template prints its own report and calls sys.exit(1) on what it cannot map.
        with _quiet(complaint):
            content: str = evaluate_template(template, data)
    except SystemExit:
        raise _ConversionFailed(" ".join(complaint.getvalue().split()) or "it exited") from None
    except Exception as error:
        raise _ConversionFailed(_one_line(error)) from None
    # rosidl_adapter.msg.string_to_idl_string_literal turns the UTF-8 bytes of a string default,
    # constant or comment into one character each (`.encode().decode('unicode_escape')`), so "é"
    # comes out as "Ã©". rosidl's build undoes it: convert_msg_to_idl (and its srv/action twins)
    # writes the .idl with expand_template(..., encoding='iso-8859-1') and rosidl_parser's
    # parse_idl_file reads it back with read_text(encoding='utf-8'). Making the same round trip
    # gives the text rosidl's build parses, and fails where that build fails.
    try:
        return content.encode("iso-8859-1").decode("utf-8")
    except UnicodeEncodeError as error:
        character = error.object[error.start]
        reason = f"{character!r} is not ISO-8859-1, the encoding rosidl writes IDL in"
    except UnicodeDecodeError as error:
        wrong = error.object[error.start : error.end]
        reason = f"bytes {wrong!r} are not UTF-8, the encoding rosidl reads IDL in"
    raise _ConversionFailed(reason)


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


def _failing_line(package: str, path: Path, text: str, *, upto: _Stage) -> int | None:
    """A line at fault in its message, in stages up to ``upto``: rosidl does not say which.
    Each message of a .srv/.action is tried on its own. None when the separators are wrong or
    the failure needs no line at all."""
    lines = text.splitlines()
    for suffix, start, stop in sections(lines, path.suffix) or ():
        name = path.stem + suffix

        def fails(first: int, end: int, name: str = name) -> bool:
            return _message_fails(package, name, lines[first:end], upto=upto)

        if fails(start, stop):
            return line_at_fault(fails, start, stop)
    return None


def _line_lark_stopped_at(
    package: str, path: Path, text: str, idl_text: str, error: Exception
) -> int | None:
    """The line declaring the member at which rosidl's IDL parser stopped in ``idl_text``, if
    that line fails on its own; None otherwise. Parsing IDL is slow (milliseconds a member), so
    this one small parse replaces the many of ``_failing_line`` where the fault is one line's."""
    stopped = getattr(error, "line", None)  # lark's UnexpectedInput says where
    if not isinstance(stopped, int):
        return None
    found = rendered_member_at(idl_text, stopped)
    if found is None:
        return None
    message, member = found
    number = line_declaring(text, member, idl=False, message=message)
    if number is None:
        return None
    alone = [text.splitlines()[number - 1]]
    return number if _message_fails(package, message, alone, upto="idl") else None


def _message_fails(package: str, name: str, lines: list[str], *, upto: _Stage) -> bool:
    from rosidl_adapter.parser import parse_message_string

    try:
        with _quiet():
            spec = parse_message_string(package, name, "\n".join(lines))
        if upto != "parse":
            data = {"pkg_name": package, "relative_input_file": f"msg/{name}.msg", "msg": spec}
            idl_text = _render_idl("msg.idl.em", data)
            if upto == "idl":
                _parse_idl_text(idl_text)
    except Exception:
        return True
    return False


def _parse_idl_text(text: str) -> Any:
    from rosidl_parser.parser import parse_idl_string

    return parse_idl_string(text)


def _parse_idl(text: str, origin: Path) -> Any:
    try:
        return _parse_idl_text(text)
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
    require_rosidl()
    if path.suffix == ".idl":
        content = _parse_idl(text, path)
    elif path.suffix in INTERFACE_SUFFIXES:
        content = _parse_interface(package, path, text)
    else:
        raise DefinitionError("not an interface file (.msg, .srv, .action or .idl)", path=path)
    try:
        _add_elements(package, path, content.elements, into)
    except DefinitionError as error:
        if error.line is not None or error.member is None:
            raise
        message = error.message if isinstance(error, MemberError) else None
        line = line_declaring(text, error.member, idl=path.suffix == ".idl", message=message)
        raise DefinitionError(error.detail, path=path, line=line) from None


def _add_origins(into: ParsedInterfaces, messages: Iterable[MessageDef], path: Path) -> None:
    """Note where each of ``messages`` is defined; a type defined twice (msg/A.msg beside A.msg,
    or one package in two folders) is refused: one definition silently replaced the other, and
    ``--compile`` failed in the C compiler."""
    for msg in messages:
        other = into.origins.get(msg.full_name)
        if other is not None and other != path:
            raise DefinitionError(f"{msg.full_name} is also defined in {other}", path=path)
    for msg in messages:
        into.origins[msg.full_name] = path


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
            _add_origins(into, [msg], path)
            into.messages.append(msg)
        elif isinstance(element, d.Service):
            srv = service_def(element, path, f"{package}.srv", element.namespaced_type.name)
            _add_origins(into, srv.messages, path)
            into.services.append(srv)
        elif isinstance(element, d.Action):
            act = action_def(element, path, f"{package}.action")
            _add_origins(into, act.messages, path)
            into.actions.append(act)
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
