"""Fast DDS's size estimate of a message, which ``rclpy.serialize_message`` pads its output to.

The wire decoders accept the few unwritten bytes such output may end with, and no more.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from pyconnect.typesys.primitives import PRIMITIVE_SIZES

Definitions = Mapping[str, tuple[str, tuple[Any, ...]]]


def fastdds_estimated_size(
    value: Any, full_name: str, definitions: Definitions, pos: int = 0
) -> int:
    """The body size Fast DDS's typesupport estimates for ``value`` (``rmw_serialize`` output).

    ``rclpy.serialization.serialize_message`` returns that many bytes, though the estimate
    aligns the elements of empty sequences of 8-byte values and serialising does not, so its
    output may end with a few unwritten bytes. The decoders accept them (and no more).
    """
    rows = definitions[full_name][1]
    if not rows:
        return pos + 1
    for name, kind, element, _bound, container, _size, _default in rows:
        field = value[name] if isinstance(value, Mapping) else getattr(value, name)
        if container == "single":
            pos = _estimate_one(field, kind, element, definitions, pos)
            continue
        if container != "array":
            pos = ((pos + 3) & -4) + 4
        if kind == "primitive":
            itemsize = PRIMITIVE_SIZES[element]
            pos = ((pos + itemsize - 1) & -itemsize) + itemsize * len(field)
        else:
            for item in field:
                pos = _estimate_one(item, kind, element, definitions, pos)
    return pos


def _estimate_one(value: Any, kind: str, element: str, definitions: Definitions, pos: int) -> int:
    if kind == "primitive":
        itemsize = PRIMITIVE_SIZES[element]
        return ((pos + itemsize - 1) & -itemsize) + itemsize
    if kind == "string":
        return ((pos + 3) & -4) + 4 + len(value.encode()) + 1
    if kind == "wstring":
        # The estimate counts a terminating wchar_t that is never written.
        return ((pos + 3) & -4) + 4 + 2 * len(value.encode("utf-16-le")) + 4
    return fastdds_estimated_size(value, element, definitions, pos)
