"""Wire codecs compiled on the fly from definition texts, as bags store them."""

from __future__ import annotations

from pathlib import Path

import pytest

from pyconnect.codecs import wire
from pyconnect.errors import CodecNotFoundError, DecodeError
from pyconnect.typesys import definition_text
from pyconnect.typesys.packages import installed_packages

SEPARATOR = "=" * 80
HEADER_BLOCKS = f"""
{SEPARATOR}
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
{SEPARATOR}
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"""
FOXY_RANGE = """std_msgs/Header header
uint8 ULTRASOUND=0
uint8 INFRARED=1
uint8 radiation_type
float32 field_of_view
float32 min_range
float32 max_range
float32 range
"""
RANGE = {
    "header": {"stamp": {"sec": 3, "nanosec": 4}, "frame_id": "sonar"},
    "radiation_type": 1, "field_of_view": 0.5, "min_range": 0.25, "max_range": 4.0, "range": 2.0,
}  # fmt: skip


def test_a_type_the_text_defines_differently_uses_the_text() -> None:
    foxy = wire.wire_codec("sensor_msgs/msg/Range", definition=FOXY_RANGE + HEADER_BLOCKS)
    jazzy = wire.wire_codec("sensor_msgs/msg/Range")
    assert foxy.type_hash != jazzy.type_hash
    cdr = foxy.from_dict(RANGE)
    assert foxy.to_dict(cdr) == RANGE
    with pytest.raises(DecodeError) as caught:
        jazzy.to_dict(cdr)
    assert str(caught.value) == (
        "sensor_msgs/msg/Range.variance: truncated: float32 at offset 40 needs 4 bytes, 0 left"
    )


def test_dependencies_missing_from_the_text_come_from_installed_packages() -> None:
    codec = wire.wire_codec("sensor_msgs/Range", definition=FOXY_RANGE)
    assert codec.to_dict(codec.from_dict(RANGE)) == RANGE


def test_dependencies_neither_in_the_text_nor_installed_are_named(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # Generated code is never read back into the type model: a type must come from a text.
    monkeypatch.setattr(definition_text, "installed_packages", dict)
    text = FOXY_RANGE + "\n# std_msgs is not installed anywhere\n"
    with pytest.raises(CodecNotFoundError) as caught:
        wire.wire_codec("sensor_msgs/msg/Range", definition=text)
    assert str(caught.value) == (
        "sensor_msgs/msg/Range: bad ros2msg definition: sensor_msgs/msg/Range: unknown type "
        "std_msgs/msg/Header (not in the text, not installed)"
    )


def test_the_same_text_is_compiled_once_and_an_installed_definition_is_shared() -> None:
    text = Path(__file__).parent.joinpath("Status.msg").read_text()
    first = wire.wire_codec("my_robot_msgs/msg/Status", definition=text)
    assert wire.wire_codec("my_robot_msgs/msg/Status", definition=text) is first
    installed = Path(installed_packages()["sensor_msgs"].share, "msg/Range.msg")
    same = wire.wire_codec("sensor_msgs/msg/Range", definition=installed.read_text())
    assert same.type_hash == wire.wire_codec("sensor_msgs/msg/Range").type_hash


def test_register_definition_makes_a_new_type_decodable_by_name() -> None:
    text = Path(__file__).parent.joinpath("Status.msg").read_text()
    codec = wire.register_definition("my_robot_msgs/Status", text)
    assert codec.msg_type == "my_robot_msgs/msg/Status"
    value = {"level": 2, "names": ["arm", "base"], "temperatures": [40.5, 41.0]}
    cdr = wire.encode(value, "my_robot_msgs/msg/Status")
    decoded = wire.decode(cdr, "my_robot_msgs/Status")
    assert decoded["names"] == ["arm", "base"]
    assert decoded["temperatures"] == [40.5, 41.0]


def test_service_event_schema_is_the_srv_text() -> None:
    from rclpy.serialization import serialize_message
    from std_srvs.srv import SetBool

    text = "bool data # e.g. for hardware enabling / disabling\n---\nbool success\nstring message\n"
    codec = wire.wire_codec("std_srvs/srv/SetBool_Event", definition=text)
    event = SetBool.Event()
    event.info.event_type = 1
    event.info.sequence_number = 7
    event.request.append(SetBool.Request(data=True))
    event.response.append(SetBool.Response(success=True, message="done"))
    decoded = codec.to_dict(serialize_message(event))
    assert decoded["info"]["sequence_number"] == 7
    assert decoded["request"] == [{"data": True}]
    assert decoded["response"] == [{"success": True, "message": "done"}]


def test_ros2idl_text() -> None:
    share = installed_packages()
    header_idl = Path(share["std_msgs"].share, "msg/Header.idl").read_text()
    time_idl = Path(share["builtin_interfaces"].share, "msg/Time.idl").read_text()
    text = (
        f"IDL: std_msgs/msg/Header\n{header_idl}\n{SEPARATOR}\n"
        f"IDL: builtin_interfaces/msg/Time\n{time_idl}"
    )
    codec = wire.wire_codec("std_msgs/msg/Header", definition=text, encoding="ros2idl")
    assert codec.type_hash == wire.wire_codec("std_msgs/msg/Header").type_hash
    header = {"stamp": {"sec": 1, "nanosec": 2}, "frame_id": "map"}
    assert codec.to_dict(codec.from_dict(header)) == header


def test_bad_definitions_are_one_line_errors() -> None:
    with pytest.raises(CodecNotFoundError) as caught:
        wire.wire_codec("my_robot_msgs/msg/Broken", definition="int32 x\nnot_a_type y\n")
    assert "\n" not in str(caught.value)
    assert str(caught.value).startswith("my_robot_msgs/msg/Broken: bad ros2msg definition: ")
    with pytest.raises(CodecNotFoundError) as caught:
        wire.wire_codec("my_robot_msgs/msg/Broken", definition="x", encoding="ros1msg")
    assert str(caught.value) == (
        "my_robot_msgs/msg/Broken: bad ros1msg definition: unsupported definition encoding "
        "'ros1msg' (ros2msg or ros2idl)"
    )


def test_a_definition_without_rosidls_parsers_says_what_to_install(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """It said "bad ros2msg definition: ...": a fault of the definition, which it is not."""
    from pyconnect.codecs.registry import Registry
    from tests.missing_modules import without

    without(monkeypatch, "rosidl_adapter")
    with pytest.raises(CodecNotFoundError) as caught:
        wire.register_definition("my_other_msgs/Num", "int64 num\n", registry=Registry())
    assert str(caught.value) == (
        "my_other_msgs/Num: reading interface definitions needs rosidl's parsers (No module "
        "named 'rosidl_adapter'): pip install 'pyconnect-ros[ros]' or source a ROS 2 Jazzy install"
    )
