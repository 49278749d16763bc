"""Fast construction of rclpy messages: ``__new__`` plus writes to the backing slots.

An rclpy message's constructor builds every nested default through property setters (a
``sensor_msgs/Image()`` costs ~3 µs, mostly its Header). rosidl_generator_py stores field
``name`` in the slot ``_name``, so a codec that has already validated its values can create the
object with ``__new__`` and fill the slots directly, as the generated dict codecs do. Every
class is checked first: when its slots are not exactly ``_<field>`` (+ ``_check_fields``), the
callers use the public constructor instead.
"""

from __future__ import annotations

import operator
import os
from collections.abc import Callable
from typing import Any

# What rclpy's constructors store in _check_fields (read from the same variable).
CHECK_FIELDS = os.environ.get("ROS_PYTHON_CHECK_FIELDS", "") == "1"

_LAYOUT_OK: dict[type, bool] = {}


def has_slot_layout(*classes: type) -> bool:
    """True when every class stores each field ``f`` in the slot ``_f`` and nothing else."""
    for cls in classes:
        known = _LAYOUT_OK.get(cls)
        if known is None:
            fields = getattr(cls, "get_fields_and_field_types", None)
            slots = set(getattr(cls, "__slots__", ()))
            known = callable(fields) and slots - {"_check_fields"} == {
                f"_{name}" for name in fields()
            }
            _LAYOUT_OK[cls] = known
        if not known:
            return False
    return True


def blank(cls: type) -> Any:
    """A new instance with no field set yet (the caller sets every slot)."""
    msg: Any = object.__new__(cls)
    msg._check_fields = CHECK_FIELDS
    return msg


def zero_header(header_class: type, time_class: type) -> Any:
    """A std_msgs/Header with a zero stamp and an empty frame_id."""
    stamp = blank(time_class)
    stamp._sec = 0
    stamp._nanosec = 0
    header = blank(header_class)
    header._stamp = stamp
    header._frame_id = ""
    return header


_READERS: dict[tuple[type, tuple[str, ...]], Callable[[Any], Any]] = {}


def field_reader(cls: type, names: tuple[str, ...]) -> Callable[[Any], Any]:
    """``reader(msg)`` giving the fields ``names`` of a message of ``cls`` as a tuple.

    rclpy's properties cost ~60 ns each; their slots hold the same values, so those are read
    when ``cls`` has the rosidl layout. Anything else (the wire codecs' views, rosbags
    messages) is read by field name.
    """
    key = (cls, names)
    reader = _READERS.get(key)
    if reader is None:
        slotted = has_slot_layout(cls)
        attributes = [f"_{name}" if slotted else name for name in names]
        getter = operator.attrgetter(*attributes)
        reader = getter if len(names) > 1 else (lambda msg: (getter(msg),))
        _READERS[key] = reader
    return reader


_PATH_READERS: dict[tuple[type, tuple[str, ...]], Callable[[Any], tuple[Any, ...]]] = {}


def path_reader(msg: Any, paths: tuple[str, ...]) -> Callable[[Any], tuple[Any, ...]]:
    """``reader(m)`` giving the dotted ``paths`` (``"linear.x"``) of messages like ``msg``.

    Slots are read when every class along every path has the rosidl layout (checked on
    ``msg``, the first message of its class); otherwise the field names are.
    """
    key = (type(msg), paths)
    reader = _PATH_READERS.get(key)
    if reader is None:
        slotted = all(_path_is_slotted(msg, path) for path in paths)
        attributes = [
            ".".join(f"_{part}" for part in path.split(".")) if slotted else path for path in paths
        ]
        reader = operator.attrgetter(*attributes)
        _PATH_READERS[key] = reader
    return reader


def _path_is_slotted(msg: Any, path: str) -> bool:
    current = msg
    for part in path.split("."):
        if not has_slot_layout(type(current)):
            return False
        current = getattr(current, part)
    return True
