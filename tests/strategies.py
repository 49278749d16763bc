"""Hypothesis strategies built from the IR, so that every generated type gets round-trip tests."""

from __future__ import annotations

import math
import struct
from functools import cache
from typing import Any

from hypothesis import strategies as st

from pyconnect.codegen.build import DEFAULT_PACKAGES
from pyconnect.typesys.loading import load_packages
from pyconnect.typesys.model import ElementType, FieldType, MessageDef, PackageDef, TypeSet
from pyconnect.typesys.primitives import INTEGER_RANGES

# CDR strings are NUL-terminated, so NUL cannot travel; lone surrogates are not encodable.
SENDABLE_CHARACTERS = st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00")
UNBOUNDED_MAX = 3


@cache
def default_packages() -> tuple[dict[str, PackageDef], TypeSet]:
    """The default generated packages and every type they use, parsed once per test run."""
    return load_packages(DEFAULT_PACKAGES)


def all_types() -> TypeSet:
    return default_packages()[1]


def element_values(element: ElementType, types: TypeSet) -> st.SearchStrategy[Any]:
    if element.kind == "message":
        return message_dicts(types.get(element.name), types)
    if element.kind in ("string", "wstring"):
        return st.text(SENDABLE_CHARACTERS, max_size=element.string_bound or 12)
    name = element.name
    if name == "bool":
        return st.booleans()
    if name == "float64":
        return st.floats(allow_nan=True, allow_infinity=True)
    if name == "float32":
        return st.floats(allow_nan=True, allow_infinity=True, width=32)
    low, high = INTEGER_RANGES[name]
    return st.integers(low, high)


def field_values(ftype: FieldType, types: TypeSet) -> st.SearchStrategy[Any]:
    element = ftype.element
    if ftype.is_single:
        return element_values(element, types)
    if ftype.is_array:
        low = high = ftype.size or 0
    else:
        low, high = 0, ftype.size if ftype.size is not None else UNBOUNDED_MAX
    if element.kind == "primitive" and element.name in ("byte", "uint8", "char"):
        return st.binary(min_size=low, max_size=high)
    return st.lists(element_values(element, types), min_size=low, max_size=high)


def message_dicts(msg: MessageDef, types: TypeSet) -> st.SearchStrategy[dict[str, Any]]:
    """Valid lossless dicts of ``msg``: every field present, values within their bounds."""
    return st.fixed_dictionaries({f.name: field_values(f.type, types) for f in msg.fields})


def same_value(left: Any, right: Any) -> bool:
    """Equality where NaN equals NaN and floats compare bit for bit (so -0.0 != 0.0)."""
    if isinstance(left, float) and isinstance(right, float):
        if math.isnan(left) and math.isnan(right):
            return True
        return struct.pack("<d", left) == struct.pack("<d", right)
    if isinstance(left, dict) and isinstance(right, dict):
        return left.keys() == right.keys() and all(same_value(left[k], right[k]) for k in left)
    if isinstance(left, list) and isinstance(right, list):
        return len(left) == len(right) and all(map(same_value, left, right))
    return type(left) is type(right) and bool(left == right)
