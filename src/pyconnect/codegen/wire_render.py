"""Render CDR wire codecs: the planned steps of every type through ``wire_codecs.py.j2``.

``wire_plan`` decides the steps; the template prints them and only loops and branches.
"""

from __future__ import annotations

import keyword
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from pyconnect.codegen.templating import header, py_literal, render_template
from pyconnect.codegen.wire_plan import ModuleTables, Planner, Step, Value, is_flat, symbol
from pyconnect.typesys.model import MessageDef, PackageDef, TypeSet


# -- module context ----------------------------------------------------------------------------
@dataclass
class TypeCodec:
    """Everything the template prints for one type."""

    msg: MessageDef
    symbol: str
    fields: list[str]
    setters: list[tuple[str, bool]]  # (field name, needs setattr because it is a keyword)
    flat: bool
    steps: list[Step]
    dict_expr: str
    view_args: list[tuple[str, str]]  # (field name, view expression)
    keys: str
    definition: str


def plan_type(msg: MessageDef, types: TypeSet, tables: ModuleTables) -> TypeCodec:
    planner = Planner(msg, types, tables)
    keys = tables.keyset(msg)
    values = planner.message_body(msg, "", "d")
    planner.flush()
    top = Value(message=symbol(msg.full_name), fields=values)
    return TypeCodec(
        msg=msg,
        symbol=symbol(msg.full_name),
        fields=[f.name for f in msg.fields],
        setters=[(f.name, keyword.iskeyword(f.name)) for f in msg.fields],
        flat=is_flat(msg, types),
        steps=planner.steps,
        dict_expr=top.dict_expr(),
        view_args=[(name, value.view_expr()) for name, value in values],
        keys=keys,
        definition=definition_literal(msg),
    )


def definition_literal(msg: MessageDef) -> str:
    """The type's fields as plain data, so a module can rebuild its IR without rosidl."""
    rows = []
    for fld in msg.fields:
        ftype, element = fld.type, fld.type.element
        row = (
            fld.name, element.kind, element.name, element.string_bound, ftype.container,
            ftype.size, fld.default,
        )  # fmt: skip
        rows.append(py_literal(row))
    inner = ", ".join(rows)
    return f'("{msg.type_hash}", ({inner}{"," if len(rows) == 1 else ""}))'


def wire_context(messages: Iterable[MessageDef], types: TypeSet, source: str) -> dict[str, Any]:
    """The template context for a module holding ``messages`` and every type they refer to."""
    wanted = list(messages)
    ordered: list[MessageDef] = []
    seen: set[str] = set()
    for msg in wanted:
        for dep in types.closure(msg.full_name) if msg.full_name in types.messages else [msg]:
            if dep.full_name not in seen:
                seen.add(dep.full_name)
                ordered.append(types.messages.get(dep.full_name, dep))
    tables = ModuleTables()
    codecs = [plan_type(m, types, tables) for m in ordered]
    return {
        "header": header(source, wanted),
        "codecs": codecs,
        "exported": sorted(m.full_name for m in wanted),
        "structs": sorted((name, fmt) for fmt, name in tables.structs.items()),
        "dtypes": sorted((name, dtype) for dtype, name in tables.dtypes.items()),
        "runs": sorted(tables.runs.items()),
        "keysets": sorted(tables.keysets.items()),
    }


def render_wire_module(messages: Iterable[MessageDef], types: TypeSet, *, source: str) -> str:
    """A self-contained module of wire codecs for ``messages`` and their dependencies."""
    return render_template("wire_codecs.py.j2", wire_context(messages, types, source))


def render_wire_codecs(package: PackageDef, types: TypeSet) -> str:
    """The output kind ``wire_codecs`` of ``codecgen build``: one module per package."""
    return render_wire_module(package.all_messages, types, source=f"package {package.name}")
