"""What a generated ``from_dict`` does for each field: check inline, convert on the slow path."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from pyconnect.codegen.symbols import Symbols
from pyconnect.codegen.templating import py_literal
from pyconnect.typesys.model import Field, MessageDef
from pyconnect.typesys.primitives import FLOAT_NAMES, INTEGER_RANGES, NUMPY_DTYPES, STRUCT_CODES


@dataclass(frozen=True)
class FromDictField:
    """What the template prints for one field of a ``from_dict`` function.

    ``kind`` is ``scalar`` (get with a default, check inline, convert on the slow path),
    ``message`` (call the nested function) or ``container`` (default or convert helper).
    """

    name: str
    kind: str
    default: str = ""
    fast_check: str = ""
    slow_check: str = ""
    convert: str = ""
    store: str = "value"
    # containers: when a plain list passes ``list_check``, ``list_convert`` builds the value and
    # raises TypeError/OverflowError/ValueError on a bad element; ``convert`` then names it.
    list_check: str = ""
    list_convert: str = ""


def _scalar_field(fld: Field) -> FromDictField:
    element = fld.type.element
    segment = f'".{fld.name}"'
    name = element.name
    zero: bool | int | float | str
    if element.kind in ("string", "wstring"):
        bound = element.string_bound
        fast = "type(value) is not str" + (f" or len(value) > {bound}" if bound else "")
        # A NUL, or a lone surrogate (UTF-8 cannot encode it: only non-ASCII text may hold
        # one): check_str refuses it, naming the field.
        fast += ' or "\\x00" in value or not value.isascii()'
        slow, zero = f"check_str(value, {bound}, {segment})", ""
    elif name == "bool":
        fast, slow, zero = "type(value) is not bool", f"check_bool(value, {segment})", False
    elif name == "float64":
        fast, slow, zero = "type(value) is not float", f"check_float(value, {segment})", 0.0
    elif name == "float32":
        fast = "type(value) is not float or not -FLOAT32_MAX <= value <= FLOAT32_MAX"
        slow, zero = f"check_float32(value, {segment})", 0.0
    else:
        low, high = INTEGER_RANGES[name]
        fast = f"type(value) is not int or not {low} <= value <= {high}"
        slow, zero = f'check_int(value, {low}, {high}, "{name}", {segment})', 0
    default = py_literal(fld.default if fld.default is not None else zero)
    if name == "byte":
        slow = f"check_octet(value, {segment})"
        return FromDictField(fld.name, "scalar", default, fast, slow, store="BYTE_VALUES[value]")
    return FromDictField(fld.name, "scalar", default, fast, slow)


# array() takes True as 1 and 1.0: a list holding anything but plain numbers (a bool above all)
# goes to the checked conversion, which refuses bools. The test is spelled out inline (a C loop
# over the element types, no call of ours): it is most of what a numeric list field costs.
def _plain(kind: str) -> str:
    plain = "PLAIN_FLOATS" if kind in FLOAT_NAMES else "PLAIN_INTS"
    return f"{plain}.issuperset(map(type, value))"


def _container_field(fld: Field, symbols: Symbols) -> FromDictField:
    ftype, element = fld.type, fld.type.element
    segment = f'".{fld.name}"'
    fixed = ftype.is_array
    size = ftype.size
    defaults: tuple[Any, ...] = fld.default if isinstance(fld.default, tuple) else ()
    if element.kind == "message":
        nested = symbols.function(element.name) + "_from_dict"
        convert = f"message_list(value, {nested}, {size}, {fixed}, {segment})"
        default = f"[{nested}(EMPTY) for _ in range({size})]" if fixed else "[]"
        return FromDictField(fld.name, "container", default, convert=convert)
    if element.kind in ("string", "wstring"):
        bound = element.string_bound
        convert = f"str_list(value, {bound}, {size}, {fixed}, {segment})"
        default = _list_default(defaults, '""', fixed, size)
        if bound is None and not fixed and size is None:
            # "".join() checks every element is a str (and then for NULs) in C, much faster
            # than a Python loop.
            return FromDictField(
                fld.name, "container", default, convert=convert,
                list_check="type(value) is list", list_convert="plain_str_list(value)",
            )  # fmt: skip
        return FromDictField(fld.name, "container", default, convert=convert)
    name = element.name
    if name == "bool":
        convert = f"bool_list(value, {size}, {fixed}, {segment})"
        return FromDictField(
            fld.name, "container", _list_default(defaults, "False", fixed, size), convert=convert
        )
    if name == "byte":
        convert = f"octet_list(value, {size}, {fixed}, {segment})"
        values = tuple(f"BYTE_VALUES[{int(v)}]" for v in defaults)
        default = _list_default(values, "BYTE_VALUES[0]", fixed, size, literal=False)
        return FromDictField(fld.name, "container", default, convert=convert)
    code = STRUCT_CODES[name]
    dtype = NUMPY_DTYPES[name]
    if element.is_bytes_like:
        if fixed:
            convert = f"uint8_array(value, {size}, {segment})"
            default = _numpy_default(defaults, dtype, size)
        else:
            convert = f"uint8_sequence(value, {size}, {segment})"
            default = (
                f'array("B", {py_literal(bytes(int(v) for v in defaults))})'
                if defaults
                else 'array("B")'
            )
        return FromDictField(fld.name, "container", default, convert=convert)
    if fixed:
        convert = f'numeric_array(value, "{code}", "{dtype}", "{name}", {size}, {segment})'
        default = _numpy_default(defaults, dtype, size)
        if name == "float32":
            return FromDictField(fld.name, "container", default, convert=convert)
        return FromDictField(
            fld.name, "container", default, convert=convert,
            list_check=f"type(value) is list and len(value) == {size} and {_plain(name)}",
            list_convert=_fixed_convert(name, code, dtype),
        )  # fmt: skip
    convert = f'numeric_sequence(value, "{code}", "{name}", {size}, {segment})'
    default = f'array("{code}", {py_literal(defaults)})' if defaults else f'array("{code}")'
    if name == "float32":
        # array("f") turns out-of-range doubles into inf silently: always take the checked path.
        return FromDictField(fld.name, "container", default, convert=convert)
    bounded = f" and len(value) <= {size}" if size is not None else ""
    return FromDictField(
        fld.name, "container", default, convert=convert,
        list_check=f"type(value) is list{bounded} and {_plain(name)}",
        list_convert=f'array("{code}", value)',
    )  # fmt: skip


def _fixed_convert(name: str, code: str, dtype: str) -> str:
    """A checked list of plain numbers -> the fixed array's ndarray."""
    if name == "float64":
        # numpy converts a list of floats and ints to doubles as array("d") does, in half the
        # time of going through array("d").
        return "np.array(value, dtype=np.float64)"
    # Integers go through array(): it raises OverflowError out of range, where numpy wraps.
    return f'np.array(array("{code}", value), dtype=np.{dtype})'


def _list_default(
    values: tuple[Any, ...], zero: str, fixed: bool, size: int | None, *, literal: bool = True
) -> str:
    if values:
        return "[" + ", ".join(py_literal(v) if literal else str(v) for v in values) + "]"
    return f"[{zero}] * {size}" if fixed else "[]"


def _numpy_default(values: tuple[Any, ...], dtype: str, size: int | None) -> str:
    if values:
        return f"np.array({py_literal(values)}, dtype=np.{dtype})"
    return f"np.zeros({size}, dtype=np.{dtype})"


def from_dict_fields(msg: MessageDef, symbols: Symbols) -> list[FromDictField]:
    result = []
    for fld in msg.fields:
        if fld.type.is_single and fld.type.element.kind == "message":
            nested = symbols.function(fld.type.element.name) + "_from_dict"
            result.append(FromDictField(fld.name, "message", convert=nested))
        elif fld.type.is_single:
            result.append(_scalar_field(fld))
        else:
            result.append(_container_field(fld, symbols))
    return result
