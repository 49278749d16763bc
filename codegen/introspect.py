"""Read ROS interface definitions (installed packages, bare folders, .msg text) into the IR.

Parsing is rosidl's own: ``rosidl_adapter`` turns .msg/.srv/.action text into IDL and
``rosidl_parser`` parses IDL. This module only maps rosidl's definitions onto ``codegen.ir`` and
computes RIHS01 hashes with ``rosidl_generator_type_description``.
"""

from __future__ import annotations

import ast
import contextlib
import functools
import io
import os
import re
import sys
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from codegen.ir import (
    ActionDef,
    Constant,
    DefaultValue,
    ElementType,
    Field,
    FieldType,
    MessageDef,
    PackageDef,
    ServiceDef,
    TypeSet,
)

_IDL_PRIMITIVES = {
    "boolean": "bool", "octet": "byte", "uint8": "uint8", "int8": "int8", "int16": "int16",
    "uint16": "uint16", "int32": "int32", "uint32": "uint32", "int64": "int64",
    "uint64": "uint64", "float": "float32", "double": "float64",
}  # fmt: skip
_DUMMY_MEMBER = "structure_needs_at_least_one_member"
INTERFACE_SUFFIXES = (".msg", ".srv", ".action")


class DefinitionError(Exception):
    """A definition cannot be read: ``str()`` is one line naming the file and line."""

    def __init__(self, message: str, *, path: Path | str | None = None, line: int | None = None):
        where = ""
        if path is not None:
            where = f"{path}:{line}: " if line is not None else f"{path}: "
        super().__init__(where + message)
        self.path = path
        self.line = line


# -- finding installed packages ---------------------------------------------------------------
def ament_prefixes() -> list[Path]:
    """Install prefixes holding an ament index: AMENT_PREFIX_PATH, then this interpreter's.

    The ROS wheels put the index under the venv's ``share/`` and leave AMENT_PREFIX_PATH unset,
    so ``ament_index_python`` raises there; a sourced ROS install sets the variable.
    """
    candidates = [Path(p) for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    candidates += [Path(sys.prefix), Path(sys.base_prefix)]
    found: list[Path] = []
    for prefix in candidates:
        index = prefix / "share" / "ament_index" / "resource_index" / "rosidl_interfaces"
        if index.is_dir() and prefix not in found:
            found.append(prefix)
    return found


@dataclass(frozen=True)
class InstalledPackage:
    """An interface package found in an ament index, with its IDL files (relative to share/pkg)."""

    name: str
    share: Path
    idl_files: tuple[str, ...]


def installed_packages() -> dict[str, InstalledPackage]:
    """Every interface package the ament indexes list; earlier prefixes win, as in ament."""
    packages: dict[str, InstalledPackage] = {}
    for prefix in ament_prefixes():
        index = prefix / "share" / "ament_index" / "resource_index" / "rosidl_interfaces"
        for entry in sorted(index.iterdir()):
            if entry.name in packages:
                continue
            lines = entry.read_text(encoding="utf-8").split()
            idl = tuple(sorted(line for line in lines if line.endswith(".idl")))
            packages[entry.name] = InstalledPackage(entry.name, prefix / "share" / entry.name, idl)
    return packages


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
        raise DefinitionError(_one_line(error), path=path, line=line) from None
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


# -- mapping rosidl definitions onto the IR -----------------------------------------------------
def _element_type(rosidl_type: Any, origin: Path) -> ElementType:
    from rosidl_parser import definition as d

    if isinstance(rosidl_type, d.BasicType):
        name = _IDL_PRIMITIVES.get(rosidl_type.typename)
        if name is None:
            raise DefinitionError(f"unsupported IDL type {rosidl_type.typename!r}", path=origin)
        return ElementType("primitive", name)
    if isinstance(rosidl_type, d.AbstractWString):
        bound = rosidl_type.maximum_size if isinstance(rosidl_type, d.BoundedWString) else None
        return ElementType("wstring", "wstring", int(bound) if bound is not None else None)
    if isinstance(rosidl_type, d.AbstractString):
        bound = rosidl_type.maximum_size if isinstance(rosidl_type, d.BoundedString) else None
        return ElementType("string", "string", int(bound) if bound is not None else None)
    if isinstance(rosidl_type, d.NamespacedType):
        return ElementType("message", "/".join(rosidl_type.namespaced_name()))
    raise DefinitionError(f"unsupported IDL type {rosidl_type!r}", path=origin)


def _field_type(rosidl_type: Any, origin: Path) -> FieldType:
    from rosidl_parser import definition as d

    if isinstance(rosidl_type, d.Array):
        return FieldType(_element_type(rosidl_type.value_type, origin), "array", rosidl_type.size)
    if isinstance(rosidl_type, d.BoundedSequence):
        element = _element_type(rosidl_type.value_type, origin)
        return FieldType(element, "bounded_sequence", rosidl_type.maximum_size)
    if isinstance(rosidl_type, d.UnboundedSequence):
        return FieldType(_element_type(rosidl_type.value_type, origin), "sequence")
    return FieldType(_element_type(rosidl_type, origin))


def _scalar(value: object, element: ElementType) -> bool | int | float | str:
    if element.kind in ("string", "wstring"):
        return str(value)
    if isinstance(value, str):
        value = ast.literal_eval(value)
    if element.name == "bool":
        return bool(value)
    if element.is_float:
        return float(value)  # type: ignore[arg-type]
    return int(value)  # type: ignore[call-overload,no-any-return]


def _default(member: Any, ftype: FieldType) -> DefaultValue:
    if not member.has_annotation("default"):
        return None
    raw = member.get_annotation_value("default")["value"]
    if ftype.is_single:
        return _scalar(raw, ftype.element)
    values = ast.literal_eval(raw) if isinstance(raw, str) else raw
    return tuple(_scalar(v, ftype.element) for v in values)


def _message(
    structure: Any, constants: Iterable[Any], origin: Path, python: tuple[str, str]
) -> MessageDef:
    namespaced = structure.namespaced_type
    package, namespace = namespaced.namespaces
    fields = []
    for member in structure.members:
        if member.name == _DUMMY_MEMBER:
            continue
        ftype = _field_type(member.type, origin)
        fields.append(Field(member.name, ftype, _default(member, ftype)))
    consts = tuple(
        Constant(
            c.name, _element_type(c.type, origin), _scalar(c.value, _element_type(c.type, origin))
        )
        for c in constants
    )
    return MessageDef(
        package=package,
        namespace=namespace,
        name=namespaced.name,
        fields=tuple(fields),
        constants=consts,
        python_module=python[0],
        python_class=python[1],
    )


def _service(srv: Any, origin: Path, module: str, access: str) -> ServiceDef:
    package = srv.namespaced_type.namespaces[0]
    request = _message(srv.request_message.structure, (), origin, (module, f"{access}.Request"))
    request = _with_constants(request, srv.request_message.constants, origin)
    response = _message(srv.response_message.structure, (), origin, (module, f"{access}.Response"))
    response = _with_constants(response, srv.response_message.constants, origin)
    event = _message(srv.event_message.structure, (), origin, (module, f"{access}.Event"))
    return ServiceDef(package, srv.namespaced_type.name, request, response, event)


def _with_constants(msg: MessageDef, constants: Iterable[Any], origin: Path) -> MessageDef:
    from dataclasses import replace

    consts = tuple(
        Constant(
            c.name, _element_type(c.type, origin), _scalar(c.value, _element_type(c.type, origin))
        )
        for c in constants
    )
    return replace(msg, constants=consts)


def _action(action: Any, origin: Path, module: str) -> ActionDef:
    package = action.namespaced_type.namespaces[0]
    name = action.namespaced_type.name

    def part(message: Any, access: str) -> MessageDef:
        return _message(message.structure, message.constants, origin, (module, access))

    send_goal = _service(action.send_goal_service, origin, module, f"{name}.Impl.SendGoalService")
    get_result = _service(
        action.get_result_service, origin, module, f"{name}.Impl.GetResultService"
    )
    implicit = (
        *send_goal.messages,
        *get_result.messages,
        part(action.feedback_message, f"{name}.Impl.FeedbackMessage"),
    )
    return ActionDef(
        package,
        name,
        goal=part(action.goal, f"{name}.Goal"),
        result=part(action.result, f"{name}.Result"),
        feedback=part(action.feedback, f"{name}.Feedback"),
        implicit=implicit,
    )


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
            msg = _message(element.structure, element.constants, path, python)
            into.messages.append(msg)
            into.origins[msg.full_name] = path
        elif isinstance(element, d.Service):
            srv = _service(element, path, f"{package}.srv", element.namespaced_type.name)
            into.services.append(srv)
            for msg in srv.messages:
                into.origins[msg.full_name] = path
        elif isinstance(element, d.Action):
            act = _action(element, path, f"{package}.action")
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


_PACKAGE_NAME = re.compile(r"<name>\s*([A-Za-z][A-Za-z0-9_]*)\s*</name>")


def folder_package_name(folder: Path) -> str:
    """A bare folder's package: package.xml's <name>, else the folder's own name."""
    manifest = folder / "package.xml"
    if manifest.is_file():
        match = _PACKAGE_NAME.search(manifest.read_text(encoding="utf-8"))
        if match:
            return match.group(1)
    return folder.resolve().name


def folder_interface_files(folder: Path) -> list[Path]:
    """The .msg/.srv/.action files of a bare folder (msg/, srv/, action/ or the folder itself)."""
    files: list[Path] = []
    for sub in ("msg", "srv", "action"):
        files += sorted((folder / sub).glob(f"*.{sub}")) if (folder / sub).is_dir() else []
    files += sorted(p for p in folder.iterdir() if p.suffix in INTERFACE_SUFFIXES and p.is_file())
    return files


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


# -- hashing and assembling ---------------------------------------------------------------------
def _type_hashes(elements: Iterable[Any]) -> dict[str, str]:
    """RIHS01 hashes of every type in ``elements``, computed as rosidl's build computes them."""
    import rosidl_generator_type_description as td
    from rosidl_parser import definition as d

    individual: dict[str, Any] = {}
    for element in elements:
        if isinstance(element, d.Message):
            td.add_msg(element, individual)
        elif isinstance(element, d.Service):
            td.add_srv(element, individual)
        elif isinstance(element, d.Action):
            td.add_action(element, individual)
    serialized = {
        name: td.serialize_individual_type_description(t.namespaced_type, t.members)
        for name, t in individual.items()
    }
    hashes: dict[str, str] = {}
    for name in individual:
        try:
            full = td.extract_full_type_description(name, serialized)
        except KeyError as missing:
            raise DefinitionError(f"{name}: unknown type {missing.args[0]}") from None
        hashes[name] = td.calculate_type_hash(full)
    return hashes


def build_type_set(parsed: ParsedInterfaces) -> tuple[TypeSet, dict[str, str]]:
    """Check every reference resolves, hash every type; returns the TypeSet and all hashes."""
    from dataclasses import replace

    known = {m.full_name for m in iter_messages(parsed)}
    for msg in iter_messages(parsed):
        for nested in msg.nested_types:
            if nested not in known:
                origin = parsed.origins.get(msg.full_name)
                raise DefinitionError(
                    f"{msg.full_name}: unknown type {nested} (is its package installed?)",
                    path=origin,
                    line=_line_mentioning(origin, nested),
                )
    hashes = _type_hashes(parsed.rosidl_elements)
    types = TypeSet()
    for msg in iter_messages(parsed):
        types.messages[msg.full_name] = replace(msg, type_hash=hashes.get(msg.full_name, ""))
    return types, hashes


def _line_mentioning(origin: Path | None, full_name: str) -> int | None:
    if origin is None or not origin.is_file():
        return None
    package, _, name = full_name.split("/")
    pattern = re.compile(rf"\b({package}/)?{name}\b")
    for number, line in enumerate(origin.read_text(encoding="utf-8").splitlines(), start=1):
        if pattern.search(line.split("#", 1)[0]):
            return number
    return None


def iter_messages(parsed: ParsedInterfaces) -> Iterator[MessageDef]:
    yield from parsed.messages
    for srv in parsed.services:
        yield from srv.messages
    for act in parsed.actions:
        yield from act.messages


def package_defs(
    parsed: ParsedInterfaces, types: TypeSet, hashes: dict[str, str]
) -> dict[str, PackageDef]:
    """Group the parsed interfaces by package, with hashes filled in and names sorted."""
    from dataclasses import replace

    def hashed(msg: MessageDef) -> MessageDef:
        return types.get(msg.full_name)

    grouped: dict[str, dict[str, list[Any]]] = {}
    for msg in parsed.messages:
        grouped.setdefault(msg.package, {"m": [], "s": [], "a": []})["m"].append(hashed(msg))
    for srv in parsed.services:
        filled_srv = replace(
            srv,
            request=hashed(srv.request),
            response=hashed(srv.response),
            event=hashed(srv.event) if srv.event else None,
            type_hash=hashes.get(srv.full_name, ""),
        )
        grouped.setdefault(srv.package, {"m": [], "s": [], "a": []})["s"].append(filled_srv)
    for act in parsed.actions:
        filled_act = replace(
            act,
            goal=hashed(act.goal),
            result=hashed(act.result),
            feedback=hashed(act.feedback),
            implicit=tuple(hashed(m) for m in act.implicit),
            type_hash=hashes.get(act.full_name, ""),
        )
        grouped.setdefault(act.package, {"m": [], "s": [], "a": []})["a"].append(filled_act)
    return {
        name: PackageDef(
            name,
            messages=tuple(sorted(g["m"], key=lambda m: m.name)),
            services=tuple(sorted(g["s"], key=lambda s: s.name)),
            actions=tuple(sorted(g["a"], key=lambda a: a.name)),
        )
        for name, g in sorted(grouped.items())
    }


def load_packages(
    package_names: Iterable[str] = (), folders: Iterable[Path] = ()
) -> tuple[dict[str, PackageDef], TypeSet]:
    """Load the named installed packages and bare folders, plus every package they depend on.

    Returns the requested packages (by name) and the TypeSet of everything loaded.
    """
    installed = installed_packages()
    parsed = ParsedInterfaces()
    loaded: set[str] = set()
    requested: list[str] = []
    for folder in folders:
        name = parse_folder(Path(folder), parsed)
        loaded.add(name)
        requested.append(name)
    for name in package_names:
        if name in loaded:
            continue
        if name not in installed:
            raise DefinitionError(f"package {name!r} is not installed (see `codecgen list`)")
        parse_installed_package(installed[name], parsed)
        loaded.add(name)
        requested.append(name)
    # Pull in dependencies until every nested type resolves or no installed package has it.
    while True:
        missing = {
            nested.split("/", 1)[0] for msg in iter_messages(parsed) for nested in msg.nested_types
        } - loaded
        resolvable = sorted(p for p in missing if p in installed)
        if not resolvable:
            break
        for name in resolvable:
            parse_installed_package(installed[name], parsed)
            loaded.add(name)
    types, hashes = build_type_set(parsed)
    packages = package_defs(parsed, types, hashes)
    return {name: packages[name] for name in requested if name in packages}, types
