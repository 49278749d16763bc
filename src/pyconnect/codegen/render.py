"""Render the type model into Python modules with jinja2: one module per output kind and package.

The templates only loop and branch; what they print (expressions, literals, symbols) is computed
here from the type model, so every output kind is rendered the same way for ``codecgen build``
and for codecs generated on the fly.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

from pyconnect.codegen.formatting import LINE_LENGTH
from pyconnect.codegen.from_dict_fields import FromDictField, from_dict_fields
from pyconnect.codegen.symbols import Symbols, check_type_names
from pyconnect.codegen.templating import header, py_literal, render_template, snake_case
from pyconnect.codegen.wire_render import render_wire_codecs
from pyconnect.typesys.model import FieldType, MessageDef, PackageDef, TypeSet
from pyconnect.typesys.primitives import ROSIDL_NAMES


# -- the rosidl field-type strings (get_fields_and_field_types), pinned per type ------------------
def rosidl_type_string(ftype: FieldType) -> str:
    element = ftype.element
    if element.kind == "message":
        package, _, name = element.name.split("/")
        inner = f"{package}/{name}"
    elif element.kind in ("string", "wstring"):
        inner = element.name + (f"<{element.string_bound}>" if element.string_bound else "")
    else:
        inner = ROSIDL_NAMES.get(element.name, element.name)
    if ftype.container == "array":
        return f"{inner}[{ftype.size}]"
    if ftype.container == "bounded_sequence":
        return f"sequence<{inner}, {ftype.size}>"
    if ftype.container == "sequence":
        return f"sequence<{inner}>"
    return inner


# -- to_dict: one inline expression per type ------------------------------------------------------
def _to_dict_value(ftype: FieldType, access: str, types: TypeSet, depth: int, indent: str) -> str:
    element = ftype.element
    if ftype.is_single:
        if element.kind == "message":
            return _message_dict_literal(types.get(element.name), access, types, depth, indent)
        return f"{access}[0]" if element.name == "byte" else access
    if element.kind == "primitive":
        if element.name == "byte":
            # rclpy keeps a list of one-byte bytes (what it deserialises and from_dict builds), but
            # its setters and serialiser also take a tuple of them or any bytes-like object (b"..").
            # One class check keeps the list path a plain join.
            return (
                f'b"".join({access}) if {access}.__class__ is list'
                f" or {access}.__class__ is tuple else bytes({access})"
            )
        if element.is_bytes_like:
            return f"{access}.tobytes()"
        return f"list({access})" if element.name == "bool" else f"{access}.tolist()"
    if element.kind in ("string", "wstring"):
        return f"list({access})"
    item = f"e{depth}"
    inner_indent = indent + "    "
    body = _message_dict_literal(types.get(element.name), item, types, depth + 1, inner_indent)
    return f"[\n{inner_indent}{body}\n{inner_indent}for {item} in {access}\n{indent}]"


def _message_dict_literal(
    msg: MessageDef, access: str, types: TypeSet, depth: int, indent: str
) -> str:
    if not msg.fields:
        return "{}"
    inner = indent + "    "
    items = [
        dict_item(inner, f.name, _to_dict_value(f.type, f"{access}._{f.name}", types, depth, inner))
        for f in msg.fields
    ]
    return "{\n" + "\n".join(items) + f"\n{indent}}}"


def dict_item(indent: str, key: str, value: str) -> str:
    """One ``"key": value,`` line of a dict literal; a long value goes in parentheses below."""
    line = f'{indent}"{key}": {value},'
    if len(line) <= LINE_LENGTH or "\n" in value:
        return line
    return f'{indent}"{key}": (\n{indent}    {value}\n{indent}),'


# -- TypedDicts -----------------------------------------------------------------------------------
def typed_dict_annotation(ftype: FieldType, symbols: Symbols) -> str:
    element = ftype.element
    if element.kind == "message":
        inner = symbols.typed_dict(element.name)
    elif element.kind in ("string", "wstring"):
        inner = "str"
    elif element.name == "bool":
        inner = "bool"
    elif element.is_float:
        inner = "float"
    else:
        inner = "int"
    if ftype.is_single:
        return inner
    if element.kind == "primitive" and (element.is_bytes_like or element.name == "byte"):
        return "bytes"
    return f"list[{inner}]"


# -- module rendering -----------------------------------------------------------------------------
@dataclass(frozen=True)
class TypeEntry:
    """Everything the templates print for one message type."""

    msg: MessageDef
    short: str
    function: str
    cls: str
    typed_dict: str
    to_dict_literal: str
    from_dict_fields: list[FromDictField]
    keys: str
    rosidl_field_types: str
    typed_fields: list[tuple[str, str]] = field(default_factory=list)


def type_entry(msg: MessageDef, types: TypeSet, symbols: Symbols) -> TypeEntry:
    keys = py_literal(tuple(f.name for f in msg.fields))
    field_types = "".join(
        "\n" + dict_item(" " * 12, f.name, f'"{rosidl_type_string(f.type)}"') for f in msg.fields
    )
    return TypeEntry(
        msg=msg,
        short=msg.name,
        function=symbols.function(msg.full_name),
        cls=symbols.cls(msg.full_name),
        typed_dict=symbols.typed_dict(msg.full_name),
        to_dict_literal=_message_dict_literal(msg, "msg", types, 0, "    "),
        from_dict_fields=from_dict_fields(msg, symbols),
        keys=f"frozenset({keys})" if msg.fields else "frozenset()",
        rosidl_field_types="{" + field_types + "\n        }" if msg.fields else "{}",
        typed_fields=[(f.name, typed_dict_annotation(f.type, symbols)) for f in msg.fields],
    )


@dataclass(frozen=True)
class ClassImport:
    """``from <module> import <top> as <alias>``, then ``<symbol> = <alias>.<rest>`` if nested."""

    module: str
    top: str
    alias: str
    symbol: str
    attribute_path: str
    first: bool


def class_imports(messages: Iterable[MessageDef], symbols: Symbols) -> list[ClassImport]:
    result = []
    imported: set[str] = set()
    for msg in messages:
        top, _, rest = msg.python_class.partition(".")
        symbol = symbols.cls(msg.full_name)
        alias = symbol if not rest else f"_{msg.package}__{msg.namespace}__{top}"
        result.append(
            ClassImport(msg.python_module, top, alias, symbol, rest, alias not in imported)
        )
        imported.add(alias)
    return result


def _external_types(messages: Iterable[MessageDef], local: set[str]) -> list[str]:
    external: set[str] = set()
    for msg in messages:
        external.update(n for n in msg.nested_types if n not in local)
    return sorted(external)


def _context(
    package: PackageDef | None, messages: list[MessageDef], types: TypeSet
) -> dict[str, Any]:
    type_names = frozenset((m.package, m.name) for m in types.messages.values())
    symbols = Symbols(package.name if package is not None else None, type_names)
    check_type_names(messages, symbols)
    local = {m.full_name for m in messages}
    external = _external_types(messages, local) if package is not None else []
    source = f"package {package.name}" if package is not None else "installed classes"
    interfaces = [(m.full_name, m.type_hash) for m in messages]
    if package is not None:
        interfaces += [(s.full_name, s.type_hash) for s in package.services]
        interfaces += [(a.full_name, a.type_hash) for a in package.actions]
        # The implicit services' hashes: rmw_zenoh's action keys carry them.
        interfaces += [pair for a in package.actions for pair in a.service_hashes]
    return {
        "header": header(source, messages),
        "interfaces": sorted(interfaces),
        "package": package.name if package is not None else "",
        "entries": [type_entry(m, types, symbols) for m in messages],
        "class_imports": class_imports(messages, symbols),
        "external": [
            {
                "package": name.split("/")[0],
                "function": snake_case(name.split("/")[2]),
                "alias": symbols.function(name),
                "typed_dict": Symbols(name.split("/")[0], type_names).typed_dict(name),
                "typed_alias": symbols.typed_dict(name),
            }
            for name in external
        ],
    }


def render_index(package: PackageDef, types: TypeSet) -> str:
    return render_template("index.py.j2", _context(package, list(package.all_messages), types))


def render_typed_dicts(package: PackageDef, types: TypeSet) -> str:
    return render_template(
        "typed_dicts.py.j2", _context(package, list(package.all_messages), types)
    )


def render_dict_codecs(package: PackageDef, types: TypeSet) -> str:
    return render_template(
        "dict_codecs.py.j2", _context(package, list(package.all_messages), types)
    )


def render_self_contained_dict_codecs(messages: list[MessageDef], types: TypeSet) -> str:
    """One module with the dict codecs of ``messages`` (deps first) and nothing imported."""
    return render_template("dict_codecs.py.j2", _context(None, messages, types))


# Output kinds: module name inside generated/pyconnect_generated/<pkg>/ -> renderer.
OUTPUT_KINDS: dict[str, Callable[[PackageDef, TypeSet], str]] = {
    "index": render_index,
    "typed_dicts": render_typed_dicts,
    "dict_codecs": render_dict_codecs,
    "wire_codecs": render_wire_codecs,
}


def render_package(package: PackageDef, types: TypeSet) -> dict[str, str]:
    """Relative path -> file text for every output kind of one package."""
    files = {
        f"{package.name}/__init__.py": render_template(
            "package_init.py.j2",
            {
                "header": header(f"package {package.name}", package.all_messages),
                "package": package.name,
            },
        )
    }
    for kind, renderer in OUTPUT_KINDS.items():
        files[f"{package.name}/{kind}.py"] = renderer(package, types)
    return files
