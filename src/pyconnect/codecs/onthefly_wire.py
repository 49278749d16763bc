"""Compile wire codecs on the fly: from installed definitions, or from a bag's definition text.

The text is what rosbag2 stores with each topic: ``ros2msg`` (the main ``.msg`` text, then one
block per dependency after a ``=====`` line, headed ``MSG: pkg/Name``), ``ros2idl`` (blocks
headed ``IDL: pkg/msg/Name``), or, for Jazzy service-event topics, the raw ``.srv`` text. Types
the text defines win over installed ones (a Foxy ``sensor_msgs/Range`` without ``variance``);
types it only refers to come from installed packages, else from ``generated/``. Compiled
modules are cached by (type, text digest) and by the RIHS01 hash of the type.
"""

from __future__ import annotations

import hashlib
import importlib
import linecache
import re
import threading
from typing import Any

from pyconnect.codegen.wire_render import render_wire_module
from pyconnect.typesys.definition_text import parse_definition, split_type
from pyconnect.typesys.errors import DefinitionError
from pyconnect.typesys.loading import build_type_set, load_packages
from pyconnect.typesys.model import ElementType, Field, FieldType, MessageDef, TypeSet
from pyconnect.typesys.packages import installed_packages
from pyconnect.typesys.parse import ParsedInterfaces, iter_messages, parse_installed_package

Namespace = dict[str, Any]
_lock = threading.RLock()
_by_text: dict[tuple[str, str, str], Namespace] = {}
_by_package: dict[str, Namespace] = {}


def digest(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:20]


def compile_source(source: str, name: str) -> Namespace:
    """Execute rendered source as a module namespace; ``linecache`` keeps tracebacks readable."""
    filename = f"<pyconnect wire codecs {name}>"
    linecache.cache[filename] = (len(source), None, source.splitlines(True), filename)
    module_name = "pyconnect_wire_" + re.sub(r"\W", "_", name)
    namespace: Namespace = {"__name__": module_name}
    exec(compile(source, filename, "exec"), namespace)
    return namespace


def compile_messages(messages: list[MessageDef], types: TypeSet, name: str) -> Namespace:
    source = render_wire_module(messages, types, source=name)
    return compile_source(source, name)


def compile_installed(package: str) -> Namespace:
    """The wire codecs of an installed interface package (and its dependencies)."""
    with _lock:
        cached = _by_package.get(package)
        if cached is None:
            packages, types = load_packages([package])
            cached = compile_messages(
                list(packages[package].all_messages), types, f"installed {package}"
            )
            _by_package[package] = cached
        return cached


def _generated_definitions(package: str) -> dict[str, MessageDef]:
    try:
        module = importlib.import_module(f"pyconnect_generated.{package}.wire_codecs")
    except ImportError:
        return {}
    definitions: dict[str, tuple[str, tuple[Any, ...]]] = module.DEFINITIONS
    return {name: message_from_definition(name, row) for name, row in definitions.items()}


def message_from_definition(full_name: str, row: tuple[str, tuple[Any, ...]]) -> MessageDef:
    """Rebuild a MessageDef from the plain data a generated module keeps (``DEFINITIONS``)."""
    type_hash, fields = row
    package, namespace, name = full_name.split("/")
    return MessageDef(
        package=package,
        namespace=namespace,  # type: ignore[arg-type]
        name=name,
        fields=tuple(
            Field(fname, FieldType(ElementType(kind, element, bound), container, size), default)
            for fname, kind, element, bound, container, size, default in fields
        ),
        type_hash=type_hash,
    )


def resolve_definition(msg_type: str, text: str, encoding: str) -> tuple[MessageDef, TypeSet]:
    """The IR of ``msg_type`` as the text defines it, dependencies filled in from elsewhere."""
    package, namespace, name = split_type(msg_type)
    full_name = f"{package}/{namespace}/{name}"
    parsed = parse_definition(msg_type, text, encoding)
    defined = {m.full_name for m in iter_messages(parsed)}
    if full_name not in defined:
        raise DefinitionError(f"{full_name}: the definition text does not define it")
    installed = installed_packages()
    fallback: dict[str, MessageDef] = {}
    tried: set[str] = set()
    while True:
        known = {m.full_name for m in iter_messages(parsed)} | set(fallback)
        every = list(iter_messages(parsed)) + list(fallback.values())
        missing = sorted({n for m in every for n in m.nested_types if n not in known})
        if not missing:
            break
        progress = False
        for pkg in sorted({n.split("/")[0] for n in missing} - tried):
            tried.add(pkg)
            progress = True
            if pkg in installed:
                extra = ParsedInterfaces()
                parse_installed_package(installed[pkg], extra)
                _merge_installed(parsed, extra, defined)
            else:
                for dep_name, dep in _generated_definitions(pkg).items():
                    if dep_name not in defined:
                        fallback.setdefault(dep_name, dep)
        if not progress:
            raise DefinitionError(f"{full_name}: unknown type {missing[0]} (not in the text, "
                                  "not installed, not generated)")  # fmt: skip
    types = TypeSet()
    try:
        hashed, _ = build_type_set(parsed) if not fallback else (None, None)
    except (DefinitionError, KeyError, ValueError):
        hashed = None
    for msg in iter_messages(parsed):
        types.messages[msg.full_name] = hashed.get(msg.full_name) if hashed is not None else msg
    for dep_name, dep in fallback.items():
        types.messages.setdefault(dep_name, dep)
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


def compile_definition(
    msg_type: str, text: str, encoding: str = "ros2msg"
) -> tuple[MessageDef, Namespace]:
    """The wire codecs of ``msg_type`` compiled from its definition text (cached)."""
    key = (msg_type, encoding, digest(text))
    with _lock:
        cached = _by_text.get(key)
        if cached is not None:
            return cached["__top__"], cached
        msg, types = resolve_definition(msg_type, text, encoding)
        cache_key = ("", "rihs", msg.type_hash)
        namespace = _by_text.get(cache_key) if msg.type_hash else None
        if namespace is None or namespace["__top__"].full_name != msg.full_name:
            namespace = compile_messages([msg], types, f"{msg.full_name} {key[2]}")
            namespace["__top__"] = msg
            if msg.type_hash:
                _by_text[cache_key] = namespace
        _by_text[key] = namespace
        return msg, namespace
