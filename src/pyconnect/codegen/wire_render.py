"""Render CDR wire codecs: the planned steps of every type through ``wire_codecs.py.j2``.

``wire_plan`` decides the steps; the template prints them and only loops and branches.
"""

from __future__ import annotations

import keyword
from collections.abc import Collection, Iterable
from dataclasses import dataclass
from typing import Any

from pyconnect.codegen.symbols import Symbols, check_type_names
from pyconnect.codegen.templating import header, py_literal, render_template
from pyconnect.codegen.wire_plan import Planner, Step, Value, is_flat
from pyconnect.codegen.wire_tables import ModuleTables
from pyconnect.typesys.model import MessageDef, PackageDef, TypeSet


# -- module context ----------------------------------------------------------------------------
@dataclass
class TypeCodec:
    """Everything the template prints for one type."""

    msg: MessageDef
    cls: str  # the view class
    view: str  # the function building a view from field values
    decoder: str
    encoder: str
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
    top = Value(message=tables.view(msg.full_name), fields=values)
    return TypeCodec(
        msg=msg,
        cls=tables.cls(msg.full_name),
        view=tables.view(msg.full_name),
        decoder=tables.decoder(msg.full_name),
        encoder=tables.encoder(msg.full_name),
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


def local_types(
    messages: Iterable[MessageDef], types: TypeSet, linked: Collection[str]
) -> list[MessageDef]:
    """``messages`` and the types they use that are not ``linked``, dependencies first."""
    ordered: list[MessageDef] = []
    seen: set[str] = set()

    def visit(msg: MessageDef) -> None:
        if msg.full_name in seen:
            return
        seen.add(msg.full_name)
        for nested in msg.nested_types:
            if nested not in linked:
                visit(types.get(nested))
        ordered.append(msg)

    for msg in messages:
        visit(types.messages.get(msg.full_name, msg))
    return ordered


def wire_context(
    messages: Iterable[MessageDef],
    types: TypeSet,
    *,
    source: str,
    package: str | None,
    linked: Collection[str],
) -> dict[str, Any]:
    """The template context for a module holding ``messages`` and the types they use; the code
    of the ``linked`` ones is imported from their packages' modules."""
    wanted = list(messages)
    ordered = local_types(wanted, types, linked)
    symbols = Symbols(package, frozenset((m.package, m.name) for m in types.messages.values()))
    check_type_names(ordered, symbols)
    tables = ModuleTables(symbols, {m.full_name for m in ordered})
    codecs = [plan_type(m, types, tables) for m in ordered]
    return {
        "header": header(source, wanted),
        "codecs": codecs,
        "exported": sorted(m.full_name for m in wanted),
        "links": [tables.links[name] for name in sorted(tables.links)],
        "structs": sorted((name, fmt) for fmt, name in tables.structs.items()),
        "dtypes": sorted((name, dtype) for dtype, name in tables.dtypes.items()),
        "runs": sorted(tables.runs.items()),
        "keysets": sorted(tables.keysets.items()),
    }


def render_wire_module(
    messages: Iterable[MessageDef],
    types: TypeSet,
    *,
    source: str,
    linked: Collection[str] = frozenset(),
) -> str:
    """A module of wire codecs for ``messages`` and the types they use, for code compiled on the
    fly: every type is compiled into it except the ``linked`` ones, whose code it imports from
    generated modules (the caller checked that they are the same types, RIHS01 hash for hash)."""
    wanted = list(messages)
    linked = frozenset(linked) - {m.full_name for m in wanted}
    return render_template(
        "wire_codecs.py.j2",
        wire_context(wanted, types, source=source, package=None, linked=linked),
    )


def render_wire_codecs(package: PackageDef, types: TypeSet) -> str:
    """The output kind ``wire_codecs`` of ``codecgen build``: one module per package, linking
    the types of other packages from theirs."""
    own = list(package.all_messages)
    names = {m.full_name for m in own}
    linked = set(types.messages) - names
    context = wire_context(own, types, source=f"package {package.name}", package=package.name,
                           linked=linked)  # fmt: skip
    return render_template("wire_codecs.py.j2", context)
