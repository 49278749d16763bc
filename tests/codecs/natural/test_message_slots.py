"""Messages built through their slots are complete, equal to constructor-built ones, and the
constructor path is used when a class does not have rosidl's slot layout."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from rclpy import serialization

from pyconnect import codecs
from pyconnect.codecs import geometry, image, joint_state, message_slots
from pyconnect.codecs.message_slots import field_reader, has_slot_layout

CASES: list[tuple[str, Any]] = [
    ("sensor_msgs/msg/Image", np.arange(12, dtype=np.uint16).reshape(2, 3, 2)),
    (
        "sensor_msgs/msg/JointState",
        {"a": {"position": 1.0, "effort": 2.0}, "b": {"position": 3.0, "effort": 4.0}},
    ),
    ("sensor_msgs/msg/JointState", {"a": 1.0, "b": 2}),
    ("geometry_msgs/msg/Twist", ((1.0, 2.0, 3.0), (4.0, 5.0, 6.0))),
    ("geometry_msgs/msg/Wrench", (0.5, 0.25)),
    ("geometry_msgs/msg/Pose", ((1.0, 2.0, 3.0), (0.0, 0.0, 0.0, 1.0))),
    ("geometry_msgs/msg/Transform", ((1.0, 2.0, 3.0), (0.0, 0.0, 0.0, 1.0))),
    ("geometry_msgs/msg/Point32", (1.0, 2.0, 3.0)),
    ("geometry_msgs/msg/Quaternion", (0.0, 0.0, 0.0, 1.0)),
]


@pytest.mark.parametrize(("type_name", "value"), CASES)
def test_slot_built_messages_serialize_and_equal_constructed_ones(
    type_name: str, value: Any
) -> None:
    codec = codecs.lookup(type_name)
    msg = codec.encode(value)
    raw = serialization.serialize_message(msg)
    again = serialization.deserialize_message(raw, type(msg))
    assert again == msg
    assert repr(again) == repr(msg)


def test_constructor_path_when_the_layout_differs(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(message_slots, "_LAYOUT_OK", {})
    for module in (geometry, image, joint_state):
        monkeypatch.setattr(module, "has_slot_layout", lambda *classes: False)
    monkeypatch.setattr(image, "_CLASSES", [])
    monkeypatch.setattr(joint_state.JointStateCodec, "_classes", None)
    for cls in vars(geometry).values():
        if isinstance(cls, type) and "_build" in vars(cls):
            monkeypatch.setattr(cls, "_build", None)
    for type_name, value in CASES:
        codec = codecs.Registry().lookup(type_name)
        msg = codec.encode(value)
        assert (
            serialization.deserialize_message(serialization.serialize_message(msg), type(msg))
            == msg
        )
        assert repr(msg) == repr(codecs.lookup(type_name).encode(value))


def test_layout_check_and_reader() -> None:
    from sensor_msgs.msg import Image

    class NotRosidl:
        __slots__ = ("height",)

    assert has_slot_layout(Image)
    assert not has_slot_layout(NotRosidl)
    msg = Image(height=3, width=4)
    assert field_reader(Image, ("height", "width"))(msg) == (3, 4)
    assert field_reader(Image, ("height",))(msg) == (3,)
