"""VALUE of ``topic pub``, ``service call`` and ``action send_goal``: YAML text to a message.

The text is YAML (JSON is YAML) read with YAML 1.2's numbers, so ``1e-3`` is a number as in JSON
and ``017`` is 17 (PyYAML reads YAML 1.1, where they are a string and 15); its other scalars stay
as PyYAML, and so ``ros2 topic pub``, reads them (``yes`` is true). A JSON escape pair for a
character beyond U+FFFF (``"\\ud83d\\ude00"``) is that one character. It holds the message's
fields as a dict, or the type's natural value; a list given for a type whose natural value is an
ndarray (the ``*MultiArray`` types, Polygon) becomes one. As ``ros2 topic pub`` does, ``now`` in a
builtin_interfaces/Time field and ``auto`` in a std_msgs/Header field (frame_id left empty)
stand for the current time, taken again at each ``MessageTemplate.stamped()`` (each publish).
"""

from __future__ import annotations

import re
import sys
import time
import typing
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import yaml

from pyconnect import codecs
from pyconnect.codecs.field_checks import check_float, check_float32, check_int
from pyconnect.codecs.field_path import FieldError
from pyconnect.commands.graph import CommandFailed
from pyconnect.commands.yaml12 import (
    TOO_DEEP,
    OverflowedFloat,
    SelfReference,
    TooDeep,
    Yaml12Loader,
)
from pyconnect.typesys.primitives import INTEGER_RANGES

__all__ = [
    "MessageTemplate",
    "OverflowedFloat",
    "Yaml12Loader",
    "message_from_text",
    "message_template",
]

_TIME = "builtin_interfaces/msg/Time"
_HEADER = "std_msgs/msg/Header"


# PyYAML reads the escape pair \ud83d\ude00 as two surrogates, not as the character they encode.
_SURROGATE = re.compile(r"[\ud800-\udfff]")

_Path = tuple[str | int, ...]


@dataclass
class MessageTemplate:
    """A message built from VALUE and the paths of the Time fields that say ``now``."""

    message: Any
    now_paths: list[_Path] = field(default_factory=list)

    def stamped(self) -> Any:
        """The message with every ``now`` (and ``auto`` header) set to the current time."""
        if self.now_paths:
            sec, nanosec = divmod(time.time_ns(), 1_000_000_000)
            for path in self.now_paths:
                stamp = self.message
                for step in path:
                    stamp = stamp[step] if isinstance(step, int) else getattr(stamp, step)
                stamp.sec, stamp.nanosec = sec, nanosec
        return self.message


def message_from_text(text: str, msg_class: type) -> Any:
    """A message of ``msg_class`` from YAML/JSON: its fields as a dict, or its natural value;
    ``now``/``auto`` stamped once."""
    return message_template(text, msg_class).stamped()


def message_template(text: str, msg_class: type) -> MessageTemplate:
    """Parse VALUE for ``msg_class``; ``stamped()`` gives the message (re-stamped each call)."""
    try:
        value = yaml.load(text, Loader=Yaml12Loader) if text.strip() else {}
    except TooDeep:
        raise CommandFailed(TOO_DEEP) from None
    except SelfReference as error:
        raise CommandFailed(f"VALUE cannot hold itself: {' '.join(str(error).split())}") from None
    except yaml.YAMLError as error:
        raise CommandFailed(f"VALUE is not YAML or JSON: {' '.join(str(error).split())}") from None
    except RecursionError:  # the parser recurses per level: 900 '[' overflow it
        raise CommandFailed(TOO_DEEP) from None
    try:
        value = _settled(value, msg_class.__name__)
        value, now_paths = _take_now(value, msg_class, ())
        if _is_fields(value, msg_class):
            return MessageTemplate(codecs.from_dict(value, msg_class), now_paths)
        return MessageTemplate(codecs.encode(_natural(value, msg_class), msg_class))
    except CommandFailed:
        raise
    except RecursionError:  # fewer levels than the parser's limit may still exceed the walks'
        raise CommandFailed(TOO_DEEP) from None
    except Exception as error:
        raise CommandFailed(str(error)) from None


def _settled(value: Any, path: str) -> Any:
    """``value`` with each surrogate pair in its strings made the one character it encodes;
    ``FieldError`` at ``path`` for a float that overflowed (an ``OverflowedFloat``).

    JSON escapes a character beyond U+FFFF as a pair (``json.dumps``, and so ``--json``, print
    U+1F600 as ``\\ud83d\\ude00``); PyYAML keeps the two halves. A lone half stays, for the
    string field to refuse as text UTF-8 cannot hold."""
    if isinstance(value, str):
        if _SURROGATE.search(value) is None:
            return value
        return value.encode("utf-16", "surrogatepass").decode("utf-16", "surrogatepass")
    if isinstance(value, OverflowedFloat):
        raise FieldError(
            path,
            f"expected a number within float64's range (|x| <= {sys.float_info.max!r}; "
            f".inf and -.inf are infinity), got {value.text}",
        )
    if isinstance(value, list):
        return [_settled(item, f"{path}[{index}]") for index, item in enumerate(value)]
    if isinstance(value, dict):
        return {
            _settled(key, path): _settled(item, f"{path}{_key_step(key)}")
            for key, item in value.items()
        }
    return value


def _key_step(key: Any) -> str:
    """A mapping key as a step of a path: ``.name`` for a field name, ``[key]`` for others."""
    return f".{key}" if isinstance(key, str) and key.isidentifier() else f"[{key!r}]"


def _is_fields(value: Any, msg_class: type) -> bool:
    """Whether a dict VALUE holds the message's fields (else it is its natural value)."""
    if not isinstance(value, dict):
        return False
    fields = msg_class.get_fields_and_field_types()  # type: ignore[attr-defined]
    if set(value) <= set(fields):
        return True
    # Other keys: a natural value only where the type's natural value can be a mapping
    # (JointState's joints by name); for any other type a misspelt field, which from_dict names
    # (`Twist: unknown field 'linaer'`), where the natural codec would only refuse a dict.
    codec = codecs.default_registry.value_codec(msg_class)
    return codec is not None and not _may_decode_to_mapping(codec)


# A nested message field's type as rosidl writes it: pkg/Name, sequence<pkg/Name[, N]>, pkg/Name[N]
_NESTED = re.compile(r"(sequence<)?(\w+)/(\w+)(?:, \d+)?>?(\[\d+\])?")


def _take_now(value: Any, msg_type: type | str, path: _Path) -> tuple[Any, list[_Path]]:
    """``value`` with each ``now``/``auto`` replaced by a default field, and the paths of the
    Time fields they stand for (as rosidl_runtime_py's ``set_message_fields`` finds them).

    ``msg_type``: the class at the top (a service's Request has no name to import it by), the
    ``pkg/msg/Name`` of a nested field below it."""
    from pyconnect.ros.interfaces import interface_class, interface_name

    type_name = msg_type if isinstance(msg_type, str) else interface_name(msg_type)
    if value == "now" and type_name == _TIME:
        return {}, [path]
    if value == "auto" and type_name == _HEADER:
        return {}, [(*path, "stamp")]
    if not isinstance(value, dict):
        return value, []
    msg_class = interface_class(msg_type, kind="msg")
    if not _is_fields(value, msg_class):
        return value, []  # a natural value: its codec reads it as it is
    field_types: dict[str, str] = msg_class.get_fields_and_field_types()
    taken: dict[str, Any] = {}
    paths: list[_Path] = []
    for name, item in value.items():
        nested = _NESTED.fullmatch(field_types.get(name, ""))  # no such field: from_dict says
        if nested is None:
            taken[name] = item
            continue
        item_type = f"{nested.group(2)}/msg/{nested.group(3)}"
        if (nested.group(1) or nested.group(4)) and isinstance(item, list):
            elements = []
            for index, element in enumerate(item):
                taken_element, found = _take_now(element, item_type, (*path, name, index))
                elements.append(taken_element)
                paths += found
            taken[name] = elements
        else:
            taken[name], found = _take_now(item, item_type, (*path, name))
            paths += found
    return taken, paths


def _natural(value: Any, msg_class: type) -> Any:
    """VALUE as the codec takes it: lists become tuples, or one ndarray when the natural value
    is an ndarray (asked of the codec: the return type of its ``decode``)."""
    codec = codecs.default_registry.value_codec(msg_class)
    if isinstance(value, list) and codec is not None and _decodes_to_ndarray(codec):
        dtype = getattr(codec, "dtype", None)
        if dtype is None and not value:
            return value  # numpy's [] is of shape (0,), which an (N, 3) codec refuses
        # A codec with one dtype (the *MultiArray types) holds the list's elements in ``data``.
        path = f"{msg_class.__name__}.data" if dtype is not None else msg_class.__name__
        return _as_array(value, dtype, path)
    return _tuples(value)


def _decoded_type(codec: Any) -> Any:
    """What the codec's ``decode`` says it returns (its origin: ``dict`` for ``dict[str, X]``);
    None when it does not say, or its annotations do not resolve (a user codec)."""
    try:
        returned = typing.get_type_hints(codec.decode).get("return")
    except Exception:
        return None
    return typing.get_origin(returned) or returned


def _decodes_to_ndarray(codec: Any) -> bool:
    return _decoded_type(codec) is np.ndarray


def _may_decode_to_mapping(codec: Any) -> bool:
    decoded = _decoded_type(codec)
    if decoded is None or decoded is Any or decoded is object or not isinstance(decoded, type):
        return True  # it does not say: take a dict as its natural value, as before
    return issubclass(decoded, Mapping)


def _as_array(value: list[Any], dtype: np.dtype[Any] | None, path: str) -> np.ndarray[Any, Any]:
    """``value`` as an ndarray of ``dtype`` (None: numpy's choice); ``path`` names it in errors
    (``Int8MultiArray.data[1]: expected int8 in [-128, 127], got -200``)."""
    _check_rectangular(value, path)
    if dtype is None:
        return np.asarray(value)
    # Checked here, not left to numpy and the codec: numpy takes [] as float64 (which no int
    # type takes), YAML ints as int64 (a narrowing cast the codec refuses), bools as numbers,
    # and casts 1e40 to a float32 inf; and the codec's error cannot name the element.
    _check_elements(value, dtype, path)
    return np.array(value, dtype=dtype)


def _check_rectangular(value: list[Any], path: str) -> None:
    """Refuse a nested list whose rows differ in length or mix lists and scalars: numpy's own
    message for it names neither the field nor the rows."""
    rows = [len(row) if isinstance(row, list) else None for row in value]
    for index, row in enumerate(rows):
        if row != rows[0]:
            raise FieldError(path, f"ragged nested list: {_rows(index, row, rows[0])}")
    if rows and rows[0] is not None:
        for index, row in enumerate(value):
            _check_rectangular(row, f"{path}[{index}]")


def _rows(index: int, length: int | None, first: int | None) -> str:
    if length is None:
        return f"row {index} is not a list, row 0 is a list of {first} elements"
    if first is None:
        return f"row {index} is a list of {length} elements, row 0 is not a list"
    return f"row {index} has {length} elements, row 0 has {first}"


def _check_elements(value: list[Any], dtype: np.dtype[Any], path: str) -> None:
    """Raise ``FieldError`` for the first element of the (nested) ``value`` that ``dtype``
    does not hold: a bool, a str, a float for an int type, a number out of its range."""
    kind = dtype.name
    low, high = INTEGER_RANGES.get(kind, (0, -1))
    for index, element in enumerate(value):
        if isinstance(element, list):
            _check_elements(element, dtype, f"{path}[{index}]")
            continue
        if element.__class__ is int and low <= element <= high:
            continue  # the common case, without a call
        try:
            if kind in INTEGER_RANGES:
                check_int(element, low, high, kind, "")
            elif kind == "float32":
                check_float32(element, "")
            else:
                check_float(element, "")
        except FieldError as error:
            raise error.within(f"[{index}]").within(path) from None


def _tuples(value: Any) -> Any:
    if isinstance(value, list):
        return tuple(_tuples(item) for item in value)
    if isinstance(value, dict):
        return {key: _tuples(item) for key, item in value.items()}
    return value
