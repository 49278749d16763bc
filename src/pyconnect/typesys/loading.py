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
from pyconnect.typesys.packages import installed_packages
from pyconnect.typesys.parse import (
    ParsedInterfaces,
    iter_messages,
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
    hashes = rihs01_hashes(parsed.rosidl_elements)
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
