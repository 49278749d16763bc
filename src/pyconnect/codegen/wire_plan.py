"""Plan CDR wire codecs: the straight-line steps each type's decoder and encoder take.

The planner walks a message's fields once and tracks what is known statically about the
position modulo 8, so that runs of fixed-size values become one ``struct`` call with explicit
padding, and alignment is computed at run time only after a variable-length field. Fixed-size
("flat") nested messages such as ``Time`` or ``Pose`` are inlined into their parent's runs.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from pyconnect.codegen.templating import py_literal
from pyconnect.codegen.wire_tables import ModuleTables, RunItem, ValueCheck
from pyconnect.typesys.model import Field, FieldType, MessageDef, TypeSet
from pyconnect.typesys.primitives import BYTE_NAMES, FLOAT_NAMES, PRIMITIVE_SIZES, STRUCT_CODES


def is_flat(msg: MessageDef, types: TypeSet) -> bool:
    """True when every value of the type has the same size: inlined into its parent's runs."""
    for fld in msg.fields:
        element = fld.type.element
        if fld.type.container not in ("single", "array"):
            return False
        if element.kind in ("string", "wstring"):
            return False
        if element.kind == "message" and (
            not fld.type.is_single or not is_flat(types.get(element.name), types)
        ):
            return False
    return True


def min_size(msg: MessageDef, types: TypeSet) -> int:
    """A lower bound of the encoded size of any value (padding ignored): caps sequence lengths."""
    if not msg.fields:
        return 1
    total = 0
    for fld in msg.fields:
        element, ftype = fld.type.element, fld.type
        if ftype.is_sequence or element.kind in ("string", "wstring"):
            each = 4
        elif element.kind == "message":
            each = min_size(types.get(element.name), types)
        else:
            each = PRIMITIVE_SIZES[element.name]
        total += each * (ftype.size or 1) if ftype.is_array else each
    return total


# -- value expressions -----------------------------------------------------------------------
@dataclass
class Value:
    """How a decoded field's value is built from locals: a local, a list of locals, a message."""

    local: str = ""
    items: list[str] = field(default_factory=list)
    is_list: bool = False
    message: str = ""  # the view function of an inlined flat message
    fields: list[tuple[str, Value]] = field(default_factory=list)

    def dict_expr(self) -> str:
        if self.message:
            inner = ", ".join(f'"{name}": {value.dict_expr()}' for name, value in self.fields)
            return "{" + inner + "}"
        if self.is_list:
            return "[" + ", ".join(self.items) + "]"
        return self.local

    def view_expr(self) -> str:
        if self.message:
            args = ", ".join(value.view_expr() for _, value in self.fields)
            return f"{self.message}({args})"
        if self.is_list:
            return "[" + ", ".join(self.items) + "]"
        return self.local


# -- steps -------------------------------------------------------------------------------------
@dataclass
class Step:
    """One step of a decoder and the matching step of the encoder."""

    kind: str
    label: str = '""'  # decode: what `f` names while this step runs
    elabel: str = '""'  # encode: the same
    data: dict[str, Any] = field(default_factory=dict)

    def __getattr__(self, name: str) -> Any:
        try:
            return self.__dict__["data"][name]
        except KeyError:
            raise AttributeError(name) from None


@dataclass
class Run:
    items: list[RunItem] = field(default_factory=list)

    @property
    def size(self) -> int:
        return sum(item.size for item in self.items)


def _struct_format(items: Sequence[RunItem], codes: dict[str, str]) -> str:
    parts: list[str] = []
    for item in items:
        parts.append(f"{item.size}x" if item.kind == "pad" else codes[item.kind])
    # Collapse repeats ("ddd" -> "3d") so the formats stay short and readable.
    collapsed: list[str] = []
    for part in parts:
        if collapsed and not part[0].isdigit() and collapsed[-1].lstrip("0123456789") == part:
            count = collapsed[-1][:-1]
            collapsed[-1] = f"{int(count or 1) + 1}{part}"
        else:
            collapsed.append(part)
    return "".join(collapsed)


class Planner:
    """Builds the steps of one message type's decoder and encoder."""

    def __init__(self, msg: MessageDef, types: TypeSet, tables: ModuleTables) -> None:
        self.msg = msg
        self.types = types
        self.tables = tables
        self.steps: list[Step] = []
        self.run: Run | None = None
        # Known about `pos` at this point: pos % modulus == residue. A function's start is
        # unknown (the same function decodes nested values at any offset).
        self.modulus = 1
        self.residue = 0
        self.counter = 0

    # -- locals and state ------------------------------------------------------------------
    def local(self, prefix: str) -> str:
        self.counter += 1
        return f"{prefix}{self.counter}"

    def _static_pad(self, align: int) -> int | None:
        if align <= 1:
            return 0
        if align > self.modulus:
            return None
        return (-self.residue) % align

    def _advance(self, size: int) -> None:
        self.residue = (self.residue + size) % self.modulus

    def _forget(self, modulus: int = 1) -> None:
        self.modulus, self.residue = modulus, 0

    def flush(self) -> None:
        run, self.run = self.run, None
        if run is None or not run.items:
            return
        values = [item for item in run.items if item.kind != "pad"]
        targets = ", ".join(item.target for item in values) + ("," if len(values) == 1 else "")
        sources = ", ".join(item.source for item in values)
        checks = [item.check for item in values if item.check is not None]
        as_tuple = "(" + sources + ("," if len(values) == 1 else "") + ")"
        self.steps.append(
            Step(
                "run",
                label=self.tables.run_label(self.msg, run.items),
                data={
                    # One format both ways: "?" decodes any non-zero byte as True, as rclpy does.
                    "decoder": self.tables.struct(_struct_format(run.items, STRUCT_CODES)),
                    "encoder": self.tables.struct(_struct_format(run.items, STRUCT_CODES)),
                    "targets": targets,
                    "sources": sources,
                    "checks": checks,
                    "as_tuple": as_tuple,
                    "size": run.size,
                    "empty": not values,
                },
            )
        )

    def align(self, size: int) -> None:
        """Align ``pos`` for a value of ``size`` bytes: padding in the run when known."""
        pad = self._static_pad(size)
        if pad is None:
            self.flush()
            self.steps.append(Step("align", data={"size": size}))
            self._forget(min(size, 8))
            return
        if pad:
            self.item(RunItem("", "pad", pad))

    def item(self, item: RunItem) -> None:
        if self.run is None:
            self.run = Run()
        self.run.items.append(item)
        self._advance(item.size)

    def primitive(self, kind: str, segment: str, source: str, *, trusted: bool = False) -> str:
        """A value of a run; unless ``trusted`` (our own counts), checked into a local first:
        struct packs any object as a bool by its truth and True as 1 and 1.0, so only values of
        exactly the field's Python type pass unchecked, the rest go through the field's check
        (bools refused where numbers go, numpy scalars converted)."""
        size = PRIMITIVE_SIZES[kind]
        check = None
        if not trusted:
            held = self.local("t")
            exact = "bool" if kind == "bool" else "float" if kind in FLOAT_NAMES else "int"
            check = ValueCheck(held, source, exact, f'check_scalar("{kind}", {held}, "{segment}")')
            source = held
        self.align(size)
        target = self.local("v")
        self.item(RunItem(segment, kind, size, target, source, check))
        return target

    def pad_byte(self) -> None:
        """The one byte an empty struct takes on the wire."""
        self.item(RunItem("", "pad", 1))

    def count(self, segment: str, source: str) -> str:
        return self.primitive("uint32", segment, source, trusted=True)

    def step(self, kind: str, segment: str, **data: Any) -> None:
        self.flush()
        label = f'"{segment}"'
        self.steps.append(Step(kind, label=label, elabel=label, data=data))

    def pre(self, kind: str, segment: str, **data: Any) -> None:
        """An encoder step that must run before the current run is packed (no flush)."""
        label = f'"{segment}"'
        self.steps.append(Step(kind, label=label, elabel=label, data=data))

    # -- fields ------------------------------------------------------------------------------
    def message_body(self, msg: MessageDef, prefix: str, mapping: str) -> list[tuple[str, Value]]:
        if not msg.fields:
            self.pad_byte()
            return []
        values = []
        for fld in msg.fields:
            values.append((fld.name, self.field(fld, prefix + "." + fld.name, mapping)))
        return values

    def field(self, fld: Field, segment: str, mapping: str) -> Value:
        ftype, element = fld.type, fld.type.element
        source = f'{mapping}.get("{fld.name}", {self.default_literal(fld)})'
        if ftype.is_single and element.kind == "primitive":
            return Value(local=self.primitive(element.name, segment, source))
        if ftype.is_single and element.kind == "message":
            nested = self.types.get(element.name)
            if is_flat(nested, self.types):
                sub = self.local("m")
                keys = self.tables.keyset(nested)
                self.pre("submap", segment, target=sub, source=source, keys=keys)
                return Value(
                    message=self.tables.view(nested.full_name),
                    fields=self.message_body(nested, segment, sub),
                )
            target = self.local("v")
            self.step("message", segment, target=target, source=source,
                      decoder=self.tables.decoder(element.name),
                      encoder=self.tables.encoder(element.name))  # fmt: skip
            self._forget()
            return Value(local=target)
        if ftype.is_single and element.kind == "string":
            buffer = self.local("b")
            self.pre("encode_string", segment, target=buffer, source=source,
                     bound=element.string_bound)  # fmt: skip
            count = self.count(segment, f"len({buffer})")
            target = self.local("v")
            self.step("string", segment, target=target, count=count, buffer=buffer,
                      bound=element.string_bound)  # fmt: skip
            self._forget()
            return Value(local=target)
        if ftype.is_single:  # wstring
            target = self.local("v")
            self.step("wstring", segment, target=target, source=source, bound=element.string_bound)
            self._forget(4)
            return Value(local=target)
        return self.container(fld, segment, source)

    def container(self, fld: Field, segment: str, source: str) -> Value:
        ftype, element = fld.type, fld.type.element
        fixed = ftype.is_array
        size = ftype.size
        bound = size if ftype.container == "bounded_sequence" else None
        if element.kind == "primitive":
            itemsize = PRIMITIVE_SIZES[element.name]
            buffer, counted = self.local("b"), self.local("c")
            convert = "encode_bools" if element.name == "bool" else "encode_array"
            self.pre(convert, segment, target=buffer, counted=counted, source=source,
                     size=size, fixed=fixed, dtype=self.tables.dtype(element.name),
                     primitive=element.name)  # fmt: skip
            count = str(size) if fixed else self.count(segment, counted)
            self.flush()
            pad = self._static_pad(itemsize) if itemsize > 1 else 0
            target = self.local("v")
            kind = "bools" if element.name == "bool" else "array"
            # A numeric array decodes as an ndarray view in a view, and in a dict as the plain
            # value a live message's to_dict gives (a list, or bytes for byte arrays), read
            # straight from the buffer without numpy: one value per type.
            self.step(kind, segment, target=target, count=count, buffer=buffer, counted=counted,
                      itemsize=itemsize, pad=pad, fixed=fixed, bound=bound,
                      dtype=self.tables.dtype(element.name),
                      code=STRUCT_CODES[element.name],
                      byte_like=element.name in BYTE_NAMES)  # fmt: skip
            if fixed:
                if pad is None:
                    self._forget(min(itemsize, 8))
                else:
                    self._advance(pad)
                self._advance(itemsize * (size or 0))
            else:
                self._forget(min(itemsize, 4) if itemsize > 1 else 1)
            return Value(local=target)
        target = self.local("v")
        if element.kind in ("string", "wstring"):
            self.step("strings", segment, target=target, source=source, size=size, fixed=fixed,
                      bound=bound, string_bound=element.string_bound,
                      wide=element.kind == "wstring")  # fmt: skip
        else:
            nested = self.types.get(element.name)
            self.step("messages", segment, target=target, source=source, size=size, fixed=fixed,
                      bound=bound, decoder=self.tables.decoder(element.name),
                      encoder=self.tables.encoder(element.name),
                      min_size=min_size(nested, self.types))  # fmt: skip
        self._forget()
        return Value(local=target)

    def default_literal(self, fld: Field) -> str:
        return default_literal(fld.type, fld.default)


def default_literal(ftype: FieldType, default: Any) -> str:
    """The value a missing key encodes as: the field's default, else zero/empty."""
    element = ftype.element
    if ftype.is_single:
        if element.kind == "message":
            return "EMPTY"
        if element.kind in ("string", "wstring"):
            return py_literal(default or "")
        if element.name == "bool":
            return py_literal(bool(default))
        if element.is_float:
            return py_literal(float(default or 0.0))
        return py_literal(int(default or 0))
    if default:
        return py_literal(tuple(default))
    if ftype.is_array:
        if element.kind == "message":
            return f"(EMPTY,) * {ftype.size}"
        if element.kind in ("string", "wstring"):
            return f'("",) * {ftype.size}'
        if element.name == "bool":
            return f"(False,) * {ftype.size}"
        return (
            f"bytes({(ftype.size or 0) * PRIMITIVE_SIZES[element.name]})"
            if (element.is_bytes_like)
            else f"(0,) * {ftype.size}"
        )
    return "()"
