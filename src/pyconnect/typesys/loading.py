"""Load interface packages into the type model: parse, pull in dependencies, check, hash, group."""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import replace
from pathlib import Path
from typing import Any

from pyconnect.typesys.errors import DefinitionError
from pyconnect.typesys.hashing import rihs01_hashes
from pyconnect.typesys.model import MessageDef, PackageDef, TypeSet
from pyconnect.typesys.names import compiled_name_problem
from pyconnect.typesys.packages import installed_packages, read_text_file
from pyconnect.typesys.parse import (
    ParsedInterfaces,
    iter_messages,
    line_declaring,
    parse_folder,
    parse_installed_package,
)


def build_type_set(parsed: ParsedInterfaces) -> tuple[TypeSet, dict[str, str]]:
    """Check every reference resolves, hash every type; returns the TypeSet and all hashes."""
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
    reject_recursive_types(parsed)
    hashes = rihs01_hashes(parsed.rosidl_elements)
    types = TypeSet()
    for msg in iter_messages(parsed):
        types.messages[msg.full_name] = replace(msg, type_hash=hashes.get(msg.full_name, ""))
    return types, hashes


def reject_recursive_types(parsed: ParsedInterfaces) -> None:
    """Refuse a type that contains itself, directly or through others (``A[] children``).

    ROS 2 has no recursive types (rosidl's type descriptions and hashes cannot describe one), and
    every walk over nested types would otherwise have to guard against going round forever.
    """
    nested = {m.full_name: m.nested_types for m in iter_messages(parsed)}
    done: set[str] = set()
    trail: list[str] = []  # the types being visited, outermost first

    def visit(name: str) -> None:
        if name in done:
            return
        if name in trail:
            cycle = [*trail[trail.index(name) :], name]
            origin = parsed.origins.get(cycle[0])
            raise DefinitionError(
                f"recursive type {' -> '.join(cycle)} (a ROS type cannot contain itself)",
                path=origin,
                line=_line_mentioning(origin, cycle[1]),
            )
        trail.append(name)
        for child in nested.get(name, ()):
            visit(child)
        trail.pop()
        done.add(name)

    for name in sorted(nested):
        visit(name)


def _line_mentioning(origin: Path | None, full_name: str) -> int | None:
    if origin is None or not origin.is_file():
        return None
    package, _, name = full_name.split("/")
    pattern = re.compile(rf"\b({package}/)?{name}\b")
    for number, line in enumerate(origin.read_text(encoding="utf-8").splitlines(), start=1):
        if pattern.search(line.split("#", 1)[0]):
            return number
    return None


def package_defs(
    parsed: ParsedInterfaces, types: TypeSet, hashes: dict[str, str]
) -> dict[str, PackageDef]:
    """Group the parsed interfaces by package, with hashes filled in and names sorted."""

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
            send_goal_hash=hashes.get(f"{act.full_name}_SendGoal", ""),
            get_result_hash=hashes.get(f"{act.full_name}_GetResult", ""),
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


def reject_uncompilable_names(parsed: ParsedInterfaces, packages: Iterable[str]) -> None:
    """Refuse fields and constants of ``packages`` whose names rosidl's generated code cannot use
    (``int32 from``, ``int32 class``): rosidl builds them without an error into a package that
    does not import or compile."""
    wanted = set(packages)
    for msg in iter_messages(parsed):
        if msg.package not in wanted:
            continue
        members = [("field", f.name) for f in msg.fields]
        members += [("constant", c.name) for c in msg.constants]
        for kind, name in members:
            problem = compiled_name_problem(name)
            if problem is None:
                continue
            origin = parsed.origins.get(msg.full_name)
            line = None
            if origin is not None and origin.is_file():
                line = line_declaring(read_text_file(origin), name, idl=origin.suffix == ".idl")
            raise DefinitionError(
                f"{msg.full_name}: the {kind} name {name!r} is {problem}; rename it",
                path=origin,
                line=line,
            )


def load_packages(
    package_names: Iterable[str] = (), folders: Iterable[Path] = (), *, compiled: bool = False
) -> tuple[dict[str, PackageDef], TypeSet]:
    """Load the named installed packages and bare folders, plus every package they depend on.

    Returns the requested packages (by name) and the TypeSet of everything loaded. With
    ``compiled``, the folders are to be compiled by rosidl: names it cannot use are refused.
    """
    installed = installed_packages()
    parsed = ParsedInterfaces()
    loaded: set[str] = set()
    requested: list[str] = []
    for folder in folders:
        name = parse_folder(Path(folder), parsed)
        loaded.add(name)
        requested.append(name)
    if compiled:
        reject_uncompilable_names(parsed, requested)
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
