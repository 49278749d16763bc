"""Shared test helpers: bit-exact comparison, wire-like message views, bag locations."""

from __future__ import annotations

import array
import math
import struct
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
from hypothesis import settings

BAGS = Path(__file__).parents[3] / ".." / "shared" / "data" / "bags"
ROSBAGS_RS = BAGS / "rosbags_rs"

# Moderate example counts: the machine is shared (common.md).
EXAMPLES = settings(max_examples=60, deadline=None)


def same(a: Any, b: Any) -> bool:
    """Structural equality where floats compare by bits (NaN equals NaN) and arrays by bytes."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        if not (isinstance(a, np.ndarray) and isinstance(b, np.ndarray)):
            return False
        return (
            a.dtype == b.dtype
            and a.shape == b.shape
            and np.ascontiguousarray(a).tobytes() == np.ascontiguousarray(b).tobytes()
        )
    if isinstance(a, float) and isinstance(b, float):
        return struct.pack("<d", a) == struct.pack("<d", b)
    if isinstance(a, tuple | list) and isinstance(b, tuple | list):
        return type(a) is type(b) and len(a) == len(b) and all(map(same, a, b))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if hasattr(a, "__dataclass_fields__") and type(a) is type(b):
        return all(same(getattr(a, k), getattr(b, k)) for k in a.__dataclass_fields__)
    if isinstance(a, float) or isinstance(b, float):
        return False
    return type(a) is type(b) and a == b


def float_bits_equal(a: float, b: float) -> bool:
    return struct.pack("<d", a) == struct.pack("<d", b) or (math.isnan(a) and math.isnan(b))


_NUMERIC = {
    "float": "float32",
    "double": "float64",
    "int8": "int8",
    "uint8": "uint8",
    "octet": "uint8",
    "int16": "int16",
    "uint16": "uint16",
    "int32": "int32",
    "uint32": "uint32",
    "int64": "int64",
    "uint64": "uint64",
}


def wire_view(msg: Any) -> Any:
    """A view object like the CDR wire codecs': same attribute names, nested views, numeric
    sequences as read-only numpy arrays, strings as ``str``. Made from an rclpy message."""
    fields = type(msg).get_fields_and_field_types()
    view = SimpleNamespace()
    for name, type_name in fields.items():
        value = getattr(msg, name)
        if hasattr(type(value), "get_fields_and_field_types"):
            value = wire_view(value)
        elif (
            isinstance(value, list)
            and value
            and hasattr(type(value[0]), "get_fields_and_field_types")
        ):
            value = [wire_view(item) for item in value]
        elif isinstance(value, array.array | np.ndarray):
            element = (
                type_name.split("<", 1)[1].split(">", 1)[0]
                if "<" in type_name
                else type_name.split("[", 1)[0]
            )
            array_value = np.array(value, dtype=_NUMERIC.get(element))
            array_value.flags.writeable = False
            value = array_value
        setattr(view, name, value)
    return view
