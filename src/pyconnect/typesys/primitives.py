"""The one table of ROS primitive types: names, integer ranges, wire sizes, struct/numpy codes.

Every other module (the renderer, the CDR runtime, the validators) reads these tables; none keeps
its own copy.
"""

from __future__ import annotations

from typing import NamedTuple


class Primitive(NamedTuple):
    """One primitive: its size on the wire (CDR), ``struct`` code, numpy dtype and IDL name."""

    size: int
    struct_code: str
    dtype: str
    idl_name: str


# `char` is parsed to uint8 by rosidl_adapter, as rosidl does; `byte` is IDL's `octet`.
PRIMITIVES: dict[str, Primitive] = {
    "bool": Primitive(1, "?", "bool", "boolean"),
    "byte": Primitive(1, "B", "uint8", "octet"),
    "char": Primitive(1, "B", "uint8", "uint8"),
    "int8": Primitive(1, "b", "int8", "int8"),
    "uint8": Primitive(1, "B", "uint8", "uint8"),
    "int16": Primitive(2, "h", "int16", "int16"),
    "uint16": Primitive(2, "H", "uint16", "uint16"),
    "int32": Primitive(4, "i", "int32", "int32"),
    "uint32": Primitive(4, "I", "uint32", "uint32"),
    "int64": Primitive(8, "q", "int64", "int64"),
    "uint64": Primitive(8, "Q", "uint64", "uint64"),
    "float32": Primitive(4, "f", "float32", "float"),
    "float64": Primitive(8, "d", "float64", "double"),
}

PRIMITIVE_NAMES = tuple(PRIMITIVES)
PRIMITIVE_SIZES: dict[str, int] = {name: p.size for name, p in PRIMITIVES.items()}
STRUCT_CODES: dict[str, str] = {name: p.struct_code for name, p in PRIMITIVES.items()}
NUMPY_DTYPES: dict[str, str] = {name: p.dtype for name, p in PRIMITIVES.items()}
# The names rosidl's Python classes give in get_fields_and_field_types (boolean, octet, ...).
ROSIDL_NAMES: dict[str, str] = {"bool": "boolean", "byte": "octet", "float32": "float",
                                "float64": "double"}  # fmt: skip
# IDL basic type -> .msg primitive name (``char`` never appears: rosidl maps it to uint8).
FROM_IDL: dict[str, str] = {p.idl_name: name for name, p in PRIMITIVES.items() if name != "char"}


def _integer_range(name: str) -> tuple[int, int]:
    bits = 8 * PRIMITIVES[name].size
    if name.startswith("int"):
        return -(2 ** (bits - 1)), 2 ** (bits - 1) - 1
    return 0, 2**bits - 1


INTEGER_NAMES = ("byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32",
                 "int64", "uint64")  # fmt: skip
INTEGER_RANGES: dict[str, tuple[int, int]] = {name: _integer_range(name) for name in INTEGER_NAMES}
FLOAT_NAMES = ("float32", "float64")
# uint8, byte and char arrays and sequences are ``bytes`` in dicts.
BYTE_NAMES = frozenset(("byte", "char", "uint8"))
FLOAT32_MAX = 3.4028234663852886e38
# The smallest magnitude a float32 conversion turns into inf: FLOAT32_MAX plus half its unit in
# the last place (2**104); at that tie, round-half-to-even goes up, FLOAT32_MAX's mantissa being
# odd. struct.pack("<f") and rclpy's C conversion round anything smaller to a finite float32
# (3.4028235e38, numpy's print of FLOAT32_MAX, becomes FLOAT32_MAX), and raise or give inf here.
FLOAT32_OVERFLOW = FLOAT32_MAX + 2.0**103
# The .msg field types that are not messages: the primitives and the two string types.
MSG_BUILTIN_NAMES = frozenset((*PRIMITIVE_NAMES, "string", "wstring"))
