"""Decoded values as text: one summarised line, YAML like ``ros2 topic echo``, JSON Lines."""

from __future__ import annotations

import array
import base64
import dataclasses
import json
import math
import re
from collections.abc import Callable
from typing import Any

import numpy as np
import yaml

__all__ = [
    "ImageSummary",
    "abbreviated_fields",
    "field_of",
    "format_value",
    "plain_value",
    "to_json",
    "to_yaml",
]


class ImageSummary:
    """An image in one line: shape, dtype, encoding and mean pixel value."""

    def __init__(self, array: np.ndarray[Any, Any], encoding: str) -> None:
        self.shape = tuple(int(n) for n in array.shape)
        self.dtype = str(array.dtype)
        self.encoding = encoding
        self.mean = float(array.mean()) if array.size else math.nan

    def as_dict(self) -> dict[str, Any]:
        return {
            "shape": list(self.shape),
            "dtype": self.dtype,
            "encoding": self.encoding,
            "mean": round(self.mean, 3),
        }

    def __repr__(self) -> str:
        return (
            f"Image(shape={self.shape}, dtype={self.dtype}, encoding={self.encoding}, "
            f"mean={self.mean:.3f})"
        )


class _Summary:
    """Stands in for a big value in echo output; its repr is the summary."""

    def __init__(self, text: str) -> None:
        self.text = text

    def __repr__(self) -> str:
        return self.text


_MAX_ITEMS = 16
YAML_SEQUENCE_LIMIT = 128  # as `ros2 topic echo --truncate-length` defaults


def _summarise(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        if value.size <= _MAX_ITEMS and value.dtype.names is None:
            return _Summary(f"array({value.tolist()!r}, dtype={value.dtype})")
        return _Summary(f"ndarray(shape={value.shape}, dtype={value.dtype})")
    if isinstance(value, bytes | bytearray | memoryview):
        data = bytes(value)
        return data if len(data) <= _MAX_ITEMS else _Summary(f"<{len(data)} bytes>")
    if isinstance(value, dict):
        return {key: _summarise(item) for key, item in value.items()}
    if isinstance(value, list | tuple | array.array):  # array: rclpy's numeric sequences
        items = [_summarise(item) for item in value[:_MAX_ITEMS]]
        if len(value) > _MAX_ITEMS:
            items.append(_Summary(f"... {len(value) - _MAX_ITEMS} more"))
        return tuple(items) if isinstance(value, tuple) else items
    if isinstance(value, np.generic):
        return value.item()
    return value


def _member_type_name(member: Any) -> str:
    """A rosidl member type's name as ``ros2 topic echo --no-arr`` writes it."""
    from rosidl_parser import definition

    if isinstance(member, definition.BasicType):
        return str(member.typename)
    if isinstance(member, definition.AbstractWString):
        return "wstring"
    if isinstance(member, definition.AbstractString):
        return "string"
    if isinstance(member, definition.NamespacedType):
        return "/".join(member.namespaced_name())
    return "unknown"


def _array_text(value: Any, member: Any) -> _Summary:
    from rosidl_parser import definition

    item = _member_type_name(member.value_type)
    if isinstance(member, definition.Array):
        return _Summary(f"<array type: {item}[{member.size}]>")
    if isinstance(member, definition.BoundedSequence):
        return _Summary(f"<sequence type: {item}[{member.maximum_size}], length: {len(value)}>")
    return _Summary(f"<sequence type: {item}, length: {len(value)}>")


def abbreviated_fields(msg: Any) -> dict[str, Any]:
    """An rclpy message as a dict of its fields, each array or sequence field replaced by its
    type and length, as ``ros2 topic echo --no-arr`` shows it (``<sequence type: double,
    length: 2>``, ``<array type: double[9]>``); nested messages likewise."""
    from rosidl_parser import definition

    fields: dict[str, Any] = {}
    for name, member in zip(msg.get_fields_and_field_types(), msg.SLOT_TYPES, strict=True):
        value = getattr(msg, name)
        if isinstance(member, definition.AbstractNestedType):
            fields[name] = _array_text(value, member)
        elif hasattr(value, "get_fields_and_field_types"):
            fields[name] = abbreviated_fields(value)
        elif isinstance(value, bytes) and len(value) == 1:  # rclpy's `byte`: shown as a number
            fields[name] = value[0]
        else:
            fields[name] = value
    return fields


def format_value(value: Any) -> str:
    """One line for a decoded value, with arrays and long sequences summarised."""
    return repr(_summarise(value))


def plain_value(
    value: Any, limit: int | None = None, *, other: Callable[[Any], Any] | None = None
) -> Any:
    """Dicts, lists and scalars; sequences longer than ``limit`` end in ``'...'``.

    ``other`` sees every value first and may replace it (live messages become their dicts);
    whatever it returns is converted in turn.
    """
    if other is not None:
        value = other(value)
    if isinstance(value, np.ndarray):
        if value.dtype.names is not None:
            value = [dict(zip(value.dtype.names, row, strict=True)) for row in value.ravel()]
        else:
            value = value.tolist()
    elif isinstance(value, array.array):  # an rclpy message's numeric sequence field
        value = value.tolist()
    elif isinstance(value, bytes | bytearray | memoryview):
        value = list(bytes(value))
    elif isinstance(value, np.generic):
        value = value.item()
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        value = {f.name: getattr(value, f.name) for f in dataclasses.fields(value)}
    if isinstance(value, dict):
        return {str(key): plain_value(item, limit, other=other) for key, item in value.items()}
    if isinstance(value, list | tuple):
        items = [plain_value(item, limit, other=other) for item in value[:limit]]
        if limit is not None and len(value) > limit:
            items.append("...")
        return items
    return value


# YAML 1.1's line breaks beyond LF and CR. PyYAML writes them raw in a quoted scalar, and its
# reader folds NEL there into a space; a YAML 1.2 reader, for which none of them is a break,
# keeps the indentation written after each. Their escapes (\N, \L, \P) mean them in both.
_RAW_BREAKS = re.compile(r"[\x85\u2028\u2029]")


class _EchoDumper(yaml.SafeDumper):
    """PyYAML's safe dumper, with strings holding a YAML 1.1-only line break double-quoted."""


def _represent_str(dumper: yaml.SafeDumper, text: str) -> yaml.ScalarNode:
    if _RAW_BREAKS.search(text) is not None:
        return dumper.represent_scalar("tag:yaml.org,2002:str", text, style='"')
    return dumper.represent_str(text)


_EchoDumper.add_representer(str, _represent_str)


def to_yaml(value: Any) -> str:
    """YAML of a value as ``ros2 topic echo`` prints a message (long sequences truncated)."""
    text: str = yaml.dump(
        plain_value(value, YAML_SEQUENCE_LIMIT),
        Dumper=_EchoDumper,
        default_flow_style=False,
        sort_keys=False,
        allow_unicode=True,
        width=100,
    )
    return text.removesuffix("...\n")  # a bare scalar's document end marker


def _finite(value: Any) -> Any:
    # Imported on first use: every `pyconnect` command imports this module at start-up, and the
    # record package (the helper's home, shared with `bag export`) costs most of them ~0.1 s.
    from pyconnect.record.log_values import finite_for_json

    return finite_for_json(value)


def _json_default(value: Any) -> Any:
    if isinstance(value, bytes | bytearray | memoryview):
        return base64.b64encode(bytes(value)).decode("ascii")
    if isinstance(value, np.ndarray):
        if value.dtype == np.uint8:
            return base64.b64encode(value.tobytes()).decode("ascii")
        return _finite(plain_value(value))
    return _finite(plain_value(value))


def to_json(record: dict[str, Any]) -> str:
    """One JSON line: numeric arrays as lists, bytes and uint8 arrays as base64 strings,
    non-finite floats as the strings ``"nan"``, ``"inf"``, ``"-inf"`` (strict JSON readers
    refuse ``NaN``; ``bag export`` and the logger write them the same way)."""
    return json.dumps(_finite(record), default=_json_default, allow_nan=False)


# A lossless dict holds uint8[] and byte[] fields (Image.data) as bytes: indexed as the lists.
_INDEXABLE = (list, tuple, np.ndarray, bytes, bytearray, memoryview)


def field_of(value: Any, path: str) -> Any:
    """The field ``path`` (``pose.position.x``, ``position.0``) of a dict value; KeyError."""
    current = value
    walked: list[str] = []
    for name in path.split("."):
        if isinstance(current, dict):
            if name not in current:
                where = ".".join(walked) or "the message"
                fields = ", ".join(current) or "none"
                raise KeyError(f"no field {name!r} in {where} (fields: {fields})")
            current = current[name]
        elif isinstance(current, _INDEXABLE) and name.isdigit():
            if int(name) >= len(current):
                raise KeyError(f"{'.'.join(walked)}: no item {name} of {len(current)}")
            current = current[int(name)]
        else:
            raise KeyError(f"{'.'.join(walked) or 'the message'} has no field {name!r}")
        walked.append(name)
    return current
