"""sensor_msgs/JointState ↔ ``{"shoulder": {"position": 0.1, "velocity": 0.0, "effort": 0.0}, …}``.

Only the arrays that are non-empty in the message appear in each joint's dict. Encode also
accepts ``{"shoulder": 0.1, …}`` (positions only). Drops the header (use ``stamped=True``), so
``lossless`` is False. A received message whose non-empty arrays differ in length from
``name``, or which names a joint twice, gets a ``DecodeError`` naming them.
"""

from __future__ import annotations

import array
import numbers
from collections.abc import Callable, Mapping
from itertools import chain
from typing import Any

from pyconnect.codecs.base import FieldsCodec, check_message_type, decode_failure
from pyconnect.codecs.field_checks import PLAIN_FLOATS, check_float, check_str
from pyconnect.codecs.message_slots import blank, field_reader, has_slot_layout, zero_header
from pyconnect.errors import DecodeError, EncodeError, type_name_of

_ARRAYS = ("position", "velocity", "effort")
_STR_ONLY = {str}
_DICT_ONLY = {dict}


def _floats(values: Any) -> list[float]:
    return values.tolist() if hasattr(values, "tolist") else [float(v) for v in values]


_FIELDS = ("name", "position", "velocity", "effort")
_READERS: dict[type, Callable[[Any], Any]] = {}
_ARRAY = array.array


def decode_joint_state(msg: Any) -> dict[str, dict[str, float]]:
    """The joints of a JointState message as a dict keyed by name."""
    cls = type(msg)
    reader = _READERS.get(cls)
    if reader is None:
        check_message_type(msg, "sensor_msgs/msg/JointState")  # once per class
        reader = _READERS[cls] = field_reader(cls, _FIELDS)
    try:
        names, position, velocity, effort = reader(msg)
    except AttributeError as error:  # free until raised: a stand-in without these fields
        raise decode_failure(error, msg, "sensor_msgs/msg/JointState") from None
    count = len(names)
    if count and len(position) == count and len(velocity) == count and len(effort) == count:
        # rclpy's array('d') yields Python floats as it is iterated (a list from tolist() first
        # costs 15 % more); numpy views (CDR, bags) and user lists are converted.
        if not type(position) is type(velocity) is type(effort) is _ARRAY:
            position, velocity, effort = _floats(position), _floats(velocity), _floats(effort)
        joints = {
            n: {"position": p, "velocity": v, "effort": e}
            for n, p, v, e in zip(names, position, velocity, effort, strict=False)
        }
    else:
        columns: list[tuple[str, list[float]]] = []
        for key, values in zip(_ARRAYS, (position, velocity, effort), strict=True):
            if len(values):
                if len(values) != count:
                    raise DecodeError(
                        f"JointState.{key}: has {len(values)} values but JointState.name has "
                        f"{count}"
                    )
                columns.append((key, _floats(values)))
        joints = {n: {} for n in names}
        for key, column in columns:
            for n, v in zip(names, column, strict=True):
                joints[n][key] = v
    if len(joints) != count:
        seen: set[str] = set()
        twice = next(n for n in names if n in seen or seen.add(n))  # type: ignore[func-returns-value]
        raise DecodeError(f"JointState.name: joint {twice!r} appears more than once")
    return joints


def _fast_columns(value: Any) -> tuple[list[str], dict[str, array.array[float]]] | None:
    """Names and float columns of a well-formed joints dict, or None to take the checked path.

    The checks run in C (``map``/``set``): every joint a dict with the first joint's keys (a
    missing key raises KeyError, an extra one changes the total length), every name a str,
    every number an int or a float (array('d') would take a bool as 1.0). Whatever fails goes
    to ``joint_state_fields`` for an error naming the joint.
    """
    if type(value) is not dict or not value:
        return None
    names = list(value)
    if set(map(type, names)) != _STR_ONLY:
        return None
    joined = "".join(names)
    if "\0" in joined:
        return None
    if not joined.isascii() and not _utf8(joined):
        return None  # a lone surrogate: the checked path names the joint
    joints = list(value.values())
    first = joints[0]
    try:
        if type(first) is dict:
            keys = [k for k in _ARRAYS if k in first]
            if (
                set(map(type, joints)) != _DICT_ONLY
                or len(keys) != len(first)
                or sum(map(len, joints)) != len(keys) * len(joints)
            ):
                return None
            lists = [[j[k] for j in joints] for k in keys]
        else:
            keys, lists = ["position"], [joints]
        if not PLAIN_FLOATS.issuperset(map(type, chain.from_iterable(lists))):
            return None
        columns = dict(zip(keys, map(array.array, "ddd", lists), strict=False))
    except (KeyError, OverflowError):  # a missing key; an int beyond float's range
        return None
    return names, columns


def joint_state_fields(value: Any) -> dict[str, Any]:
    """``name``/``position``/``velocity``/``effort`` lists of a joints dict, checked."""
    if not isinstance(value, Mapping):
        raise EncodeError(
            f"JointState: expected a dict of joint name -> float or dict, got {type_name_of(value)}"
        )
    names: list[str] = []
    keys: tuple[str, ...] | None = None
    columns: dict[str, list[float]] = {"position": [], "velocity": [], "effort": []}
    for name, joint in value.items():
        if not isinstance(name, str):
            raise EncodeError(f"JointState.name: expected str, got {type_name_of(name)}")
        check_str(name, None, "JointState.name")  # a NUL: the direct path has no other check
        path = f"JointState[{name!r}]"
        if isinstance(joint, Mapping):
            joint_keys = tuple(k for k in _ARRAYS if k in joint)
            extra = [k for k in joint if k not in _ARRAYS]
            if extra:
                raise EncodeError(
                    f"{path}: unknown key {extra[0]!r} (keys: position, velocity, effort)"
                )
            for key in joint_keys:
                columns[key].append(check_float(joint[key], f"{path}.{key}"))
        elif isinstance(joint, numbers.Real) and not isinstance(joint, bool):
            joint_keys = ("position",)
            columns["position"].append(check_float(joint, path))
        else:
            raise EncodeError(f"{path}: expected float or dict, got {type_name_of(joint)}")
        if keys is None:
            keys = joint_keys
        elif joint_keys != keys:
            raise EncodeError(
                f"{path}: expected keys {', '.join(keys) or 'none'} like the joints before, "
                f"got {', '.join(joint_keys) or 'none'}"
            )
        names.append(name)
    fields: dict[str, Any] = {"name": names}
    fields.update(columns)
    return fields


class JointStateCodec(FieldsCodec):
    """sensor_msgs/JointState ↔ dict keyed by joint name."""

    msg_type = "sensor_msgs/msg/JointState"
    lossless = False
    _classes: Any = None

    decode = staticmethod(decode_joint_state)

    def to_fields(self, value: Any) -> dict[str, Any]:
        fast = _fast_columns(value)
        if fast is None:
            return joint_state_fields(value)
        names, columns = fast
        empty = array.array("d")
        return {"name": names, **{key: columns.get(key, empty) for key in _ARRAYS}}

    def encode(self, value: Any) -> Any:
        # A hot codec keeps a direct path: the generated from_dict on to_fields costs more
        # (its checks again), so the checked columns go straight into the message slots.
        classes = JointStateCodec._classes
        if classes is None:
            from builtin_interfaces.msg import Time
            from sensor_msgs.msg import JointState
            from std_msgs.msg import Header

            classes = JointStateCodec._classes = (
                JointState,
                Header,
                Time,
                has_slot_layout(JointState, Header, Time),
            )
        cls, header_class, time_class, slotted = classes
        fast = _fast_columns(value)
        if fast is None:
            fields = joint_state_fields(value)
            names = fields["name"]
            columns = {k: array.array("d", fields[k]) for k in _ARRAYS if fields[k]}
        else:
            names, columns = fast
        if not slotted:
            return cls(name=names, **columns)
        # Validated above: write the slots (array('d') is what the setters would store).
        msg = blank(cls)
        msg._header = zero_header(header_class, time_class)
        msg._name = names
        msg._position = columns.get("position") or array.array("d")
        msg._velocity = columns.get("velocity") or array.array("d")
        msg._effort = columns.get("effort") or array.array("d")
        return msg


def _utf8(text: str) -> bool:
    """Whether ``text`` can be written as UTF-8 (no lone surrogates)."""
    try:
        text.encode()
    except UnicodeEncodeError:
        return False
    return True
