"""sensor_msgs/JointState ↔ ``{"shoulder": {"position": 0.1, "velocity": 0.0, "effort": 0.0}, …}``.

Only the arrays that are non-empty in the message appear in each joint's dict. Encode also
accepts ``{"shoulder": 0.1, …}`` (positions only). Drops the header (use ``stamped=True``), so
``lossless`` is False. A received message whose non-empty arrays differ in length from
``name``, or which names a joint twice, gets a ``DecodeError`` naming them.
"""

from __future__ import annotations

import array
import numbers
from collections.abc import Mapping
from typing import Any

from pyconnect.codecs.checks import check_float
from pyconnect.errors import DecodeError, EncodeError, type_name_of

_ARRAYS = ("position", "velocity", "effort")


def _floats(values: Any) -> list[float]:
    return values.tolist() if hasattr(values, "tolist") else [float(v) for v in values]


def decode_joint_state(msg: Any) -> dict[str, dict[str, float]]:
    """The joints of a JointState message as a dict keyed by name."""
    names = msg.name
    count = len(names)
    columns: list[tuple[str, list[float]]] = []
    for key in _ARRAYS:
        values = getattr(msg, key)
        if len(values):
            if len(values) != count:
                raise DecodeError(
                    f"JointState.{key}: has {len(values)} values but JointState.name has {count}"
                )
            columns.append((key, _floats(values)))
    if len(columns) == 3:
        (k1, c1), (k2, c2), (k3, c3) = columns
        joints = {n: {k1: a, k2: b, k3: c} for n, a, b, c in zip(names, c1, c2, c3, strict=True)}
    elif len(columns) == 1:
        (k1, c1) = columns[0]
        joints = {n: {k1: a} for n, a in zip(names, c1, strict=True)}
    else:
        joints = {n: {} for n in names}
        for key, column in columns:
            for n, v in zip(names, column, strict=True):
                joints[n][key] = v
    if len(joints) != count:
        seen: set[str] = set()
        twice = next(n for n in names if n in seen or seen.add(n))  # type: ignore[func-returns-value]
        raise DecodeError(f"JointState.name: joint {twice!r} appears more than once")
    return joints


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
            columns["position"].append(float(joint))
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


class JointStateCodec:
    """sensor_msgs/JointState ↔ dict keyed by joint name."""

    msg_type = "sensor_msgs/msg/JointState"
    lossless = False
    _class: Any = None

    decode = staticmethod(decode_joint_state)

    def to_fields(self, value: Any) -> dict[str, Any]:
        return joint_state_fields(value)

    def encode(self, value: Any) -> Any:
        cls = JointStateCodec._class
        if cls is None:
            from sensor_msgs.msg import JointState

            cls = JointStateCodec._class = JointState
        fields = joint_state_fields(value)
        msg = cls()
        msg.name = fields["name"]
        # array('d') is taken as is by the rclpy setter; a list is checked element by element.
        msg.position = array.array("d", fields["position"])
        msg.velocity = array.array("d", fields["velocity"])
        msg.effort = array.array("d", fields["effort"])
        return msg
