"""Definition texts rosidl cannot build (bags) fail to compile with CodecNotFoundError, at once."""

from __future__ import annotations

import pytest

from pyconnect.codecs import wire
from pyconnect.codecs.type_code import wire_code_from_model
from pyconnect.codecs.wire_codec import WireCodec
from pyconnect.errors import CodecNotFoundError
from pyconnect.typesys.model import ElementType, Field, FieldType, MessageDef, TypeSet

_INF = "(rosidl's generated code cannot spell inf or nan)"


@pytest.mark.timeout(60)  # the recursive text used to hang here forever
@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("Node[] children\nint32 v\n",
         "msg/Node.msg: recursive type bag_msgs/msg/Node -> bag_msgs/msg/Node "
         "(a ROS type cannot contain itself)"),
        ("Leaf leaf\n" + "=" * 80 + "\nMSG: bag_msgs/Leaf\nNode[<=1] up\n",
         "msg/Leaf.msg: recursive type bag_msgs/msg/Leaf -> bag_msgs/msg/Node -> "
         "bag_msgs/msg/Leaf (a ROS type cannot contain itself)"),
        ("float64 y 1e400\n", f"msg/Node.msg:1: the default of y is not finite: inf {_INF}"),
        ("int8 a\nfloat32 X=nan\n", f"msg/Node.msg:2: the value of X is not finite: nan {_INF}"),
    ],
)  # fmt: skip
def test_unbuildable_texts_raise_codec_not_found(text: str, expected: str) -> None:
    with pytest.raises(CodecNotFoundError) as caught:
        wire.wire_codec("bag_msgs/msg/Node", definition=text)
    assert str(caught.value) == f"bag_msgs/msg/Node: bad ros2msg definition: {expected}"


@pytest.mark.timeout(60)
def test_wire_code_of_a_recursive_model_terminates() -> None:
    """The walk over nested types keeps a visited set, whatever the model it is given holds."""
    node = MessageDef(
        "rec_msgs",
        "msg",
        "Node",
        (
            Field("children", FieldType(ElementType("message", "rec_msgs/msg/Node"), "sequence")),
            Field("v", FieldType(ElementType("primitive", "int32"))),
        ),
    )
    code = wire_code_from_model(node, TypeSet({node.full_name: node}))
    codec = WireCodec(code, registry=wire.default_registry)
    value = {"children": [{"children": [], "v": 1}], "v": 7}
    assert codec.to_dict(codec.from_dict(value)) == value
