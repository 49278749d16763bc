"""Definition text of bags: what pyconnect writes for installed types and how it reads texts back."""

from __future__ import annotations

from pathlib import Path

import pytest
from rclpy.serialization import serialize_message
from std_msgs.msg import Header, String

from pyconnect.errors import CodecNotFoundError
from pyconnect.record.bag_reader import open_bag
from pyconnect.typesys.definition_text import resolve_definition
from pyconnect.typesys.errors import DefinitionError
from pyconnect.typesys.installed_definition_text import (
    DEFINITION_SEPARATOR,
    definition_encoding,
    installed_definition,
    interface_file,
)
from pyconnect.typesys.loading import load_packages
from pyconnect.typesys.model import TypeSet
from pyconnect.typesys.packages import installed_packages, installed_type_hash
from tests.typesys.idl_prefix import READING_IDL, SAMPLE_IDL, idl_share

__all__ = ["idl_share"]  # a fixture


def test_ros1_time_in_a_text_is_an_error_not_an_exit() -> None:
    with pytest.raises(DefinitionError) as caught:
        resolve_definition("my_pkg/msg/T", "int32 v\ntime t\n", "ros2msg")
    assert str(caught.value) == "msg/T.msg:2: unknown type 'time'"


def test_a_bag_text_with_ros1_time_falls_back_to_the_installed_type(tmp_path: Path) -> None:
    from mcap.writer import Writer

    with (tmp_path / "time.mcap").open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2", library="test")
        ros1_header = b"uint32 seq\ntime stamp\nstring frame_id\n"
        texts = {"/hdr": ("std_msgs/msg/Header", ros1_header), "/ok": ("std_msgs/msg/String", b"string data\n")}  # fmt: skip
        for topic, (name, text) in texts.items():
            schema = writer.register_schema(name=name, encoding="ros2msg", data=text)
            writer.register_channel(topic=topic, message_encoding="cdr", schema_id=schema)
        writer.add_message(1, log_time=1, data=serialize_message(Header(frame_id="a")), publish_time=1)  # fmt: skip
        writer.add_message(2, log_time=2, data=serialize_message(String(data="b")), publish_time=2)
        writer.finish()
    with open_bag(tmp_path / "time.mcap") as bag:
        values = [(m.topic, m.value) for m in bag]
    assert values[1] == ("/ok", "b")
    assert values[0][0] == "/hdr" and values[0][1]["frame_id"] == "a"


# -- types defined in .idl: stored as rosbag2 does, encoding ros2idl ---------------------------
SEPARATOR = "=" * 80


def test_a_type_with_only_an_idl_file_is_stored_as_ros2idl(idl_share: Path) -> None:
    text = installed_definition("idlpkg/msg/Reading")
    assert text == f"{SEPARATOR}\nIDL: idlpkg/msg/Reading\n{READING_IDL}"
    assert definition_encoding(text) == "ros2idl"


def test_a_msg_nesting_an_idl_only_type_is_stored_as_ros2idl_with_its_includes(
    idl_share: Path,
) -> None:
    text = installed_definition("idlpkg/Sample")
    assert text == (
        f"{SEPARATOR}\nIDL: idlpkg/msg/Sample\n{SAMPLE_IDL}"
        f"\n{SEPARATOR}\nIDL: idlpkg/msg/Reading\n{READING_IDL}"
    )
    message, _types = resolve_definition("idlpkg/msg/Sample", text, "ros2idl")
    assert [f.name for f in message.fields] == ["reading", "vals"]


def test_a_type_with_neither_file_names_the_msg_file(idl_share: Path) -> None:
    with pytest.raises(CodecNotFoundError, match=r"idlpkg/msg/Nothing: no Nothing\.msg in "):
        installed_definition("idlpkg/msg/Nothing")


def test_an_idl_type_is_recorded_and_read_back(idl_share: Path, tmp_path: Path) -> None:
    from mcap.reader import make_reader

    from pyconnect.codecs import wire
    from pyconnect.record.mcap_recorder import McapRecorder

    codec = wire.wire_codec(
        "idlpkg/msg/Sample", definition=installed_definition("idlpkg/msg/Sample"), encoding="ros2idl"
    )
    with McapRecorder(tmp_path / "idl.mcap") as recorder:
        recorder.add_topic("/sample", "idlpkg/msg/Sample")
        recorder.add_topic("/chatter", "std_msgs/msg/String")
        value = {"reading": {"value": 2.5, "label": "cd"}, "vals": [1, 2]}
        recorder.write("/sample", codec.from_dict(value), log_time_ns=1)
        recorder.write("/chatter", serialize_message(String(data="x")), log_time_ns=2)
    with (tmp_path / "idl.mcap").open("rb") as stream:
        schemas = make_reader(stream).get_summary().schemas.values()  # type: ignore[union-attr]
        assert {s.name: s.encoding for s in schemas} == {
            "idlpkg/msg/Sample": "ros2idl",
            "std_msgs/msg/String": "ros2msg",
        }
    with open_bag(tmp_path / "idl.mcap") as bag:
        values = [m.value for m in bag]
    assert bag.errors == []
    assert values[0]["reading"] == {"value": 2.5, "label": "cd"}
    assert list(values[0]["vals"]) == [1, 2]
    assert values[1] == "x"


def _chain(levels: int) -> str:
    """A text whose type nests ``levels`` types deep (x_msgs/L1 holds L2 ... holds an int8)."""
    blocks = [f"x_msgs/L{i + 1} f\n{DEFINITION_SEPARATOR}\nMSG: x_msgs/L{i + 1}\n" for i in range(levels)]
    return "".join(blocks) + "int8 z\n"


@pytest.mark.parametrize(
    ("text", "error"),
    [
        # rosidl's parser takes ~2 ms a declaration: this one stalled a bag read for a minute.
        ("".join(f"uint8 f{i}\n" for i in range(20_000)),
         "a type of the text has 20000 lines of declarations (at most 1000)"),
        (_chain(300), "the text defines 301 types (at most 256)"),
        # Compiled, this failed in Python's own parser ("too many nested parentheses").
        (_chain(100), "types nested more than 64 deep"),
    ],
)  # fmt: skip
def test_a_text_beyond_any_real_message_is_refused(text: str, error: str) -> None:
    with pytest.raises(DefinitionError) as caught:
        resolve_definition("x_msgs/msg/T", text, "ros2msg")
    assert str(caught.value) == f"x_msgs/msg/T: {error}"


def test_a_deep_but_plausible_text_is_read() -> None:
    message, types = resolve_definition("x_msgs/msg/T", _chain(40), "ros2msg")
    assert message.nested_types == ("x_msgs/msg/L1",)
    assert "x_msgs/msg/L40" in types.messages


# -- line ends: rosbag2 stores the .msg files verbatim, as their authors saved them ------------
_CRLF_TEXT = (
    '# a comment\nstring NAME="a # b"\nint32 X=-5\nmy_pkg/Inner inner  # nested\nint32[] arr [1, 2]\n'
    f"{DEFINITION_SEPARATOR}\nMSG: my_pkg/Inner\n# inner comment\nint64 v  # value\n"
)


@pytest.mark.parametrize("line_end", ["\r\n", "\r"], ids=["crlf", "cr"])
def test_a_text_with_windows_or_old_mac_line_ends_reads_as_with_lf(line_end: str) -> None:
    expected, expected_types = resolve_definition("my_pkg/msg/T", _CRLF_TEXT, "ros2msg")
    text = _CRLF_TEXT.replace("\n", line_end)
    message, types = resolve_definition("my_pkg/msg/T", text, "ros2msg")
    assert message == expected
    assert types.messages == expected_types.messages


def test_an_idl_text_with_crlf_line_ends_reads_as_with_lf(idl_share: Path) -> None:
    text = f"{DEFINITION_SEPARATOR}\nIDL: idlpkg/msg/Reading\n{READING_IDL}"
    expected = resolve_definition("idlpkg/msg/Reading", text, "ros2idl")[0]
    crlf = text.replace("\n", "\r\n")
    assert resolve_definition("idlpkg/msg/Reading", crlf, "ros2idl")[0] == expected


# -- service and action parts: in .msg form, and in rosbag2 Jazzy's `SRV:` layout --------------
ACTION_PARTS = [
    "Goal", "Result", "Feedback", "FeedbackMessage", "SendGoal_Request", "SendGoal_Response",
    "SendGoal_Event", "GetResult_Request", "GetResult_Response", "GetResult_Event",
]  # fmt: skip


@pytest.fixture(scope="module")
def installed_types() -> TypeSet:
    return load_packages(["test_msgs", "std_srvs", "rcl_interfaces"])[1]


@pytest.mark.parametrize(
    "msg_type",
    [
        *(f"test_msgs/action/Fibonacci_{part}" for part in ACTION_PARTS),
        "std_srvs/srv/SetBool_Event",
        "rcl_interfaces/srv/GetParameters_Event",
    ],
)
def test_the_stored_text_of_an_action_part_or_service_event_reads_back_as_installed(
    msg_type: str, installed_types: TypeSet
) -> None:
    """Action parts were unreadable (rosidl takes no `pkg/action/Name` field type), and their
    RIHS01 hashes were empty (hashed as `pkg/msg/Name`)."""
    text = installed_definition(msg_type)
    message, _types = resolve_definition(msg_type, text, definition_encoding(text))
    assert message == installed_types.get(msg_type)
    assert message.type_hash == installed_type_hash(msg_type)  # share/<pkg>/<ns>/<Name>.json's


@pytest.mark.parametrize("service", ["std_srvs/srv/SetBool", "rcl_interfaces/srv/GetParameters"])
def test_a_service_part_in_msg_form_reads_back_as_installed(
    service: str, installed_types: TypeSet
) -> None:
    package, _, name = service.split("/")
    srv_text = interface_file(package, "srv", name).read_text(encoding="utf-8")
    for part, text in zip(("Request", "Response"), srv_text.split("---\n"), strict=True):
        msg_type = f"{service}_{part}"
        message, _types = resolve_definition(msg_type, text, "ros2msg")
        assert message == installed_types.get(msg_type)
        assert message.type_hash == installed_type_hash(msg_type)


def test_an_error_in_a_part_names_the_part() -> None:
    with pytest.raises(DefinitionError) as caught:
        resolve_definition("test_msgs/action/Fibonacci_Goal", "int32 order\ntime t\n", "ros2msg")
    assert str(caught.value) == "action/Fibonacci_Goal.msg:2: unknown type 'time'"
    text = f"x_msgs/action/A_Goal goal\n{SEPARATOR}\nMSG: x_msgs/action/A_Goal\nint32 x y\n"
    with pytest.raises(DefinitionError) as caught:
        resolve_definition("x_msgs/msg/T", text, "ros2msg")
    assert str(caught.value).startswith("action/A_Goal.msg:1: ")
    assert "PyconnectPart" not in str(caught.value)


# What rosbag2 Jazzy's tests expect it to store for a service's events
# (test_local_message_definition_source.cpp: can_find_srv_deps_in_msg, can_find_srv_deps_in_idl).
_SRV_MSG_DEPS = (
    f"{SEPARATOR}\nSRV: my_srvs/srv/ComplexSrvMsg\n"
    "my_srvs/BasicMsg req\n---\nmy_srvs/BasicMsg resp\n"
    f"\n{SEPARATOR}\nMSG: my_srvs/BasicMsg\nfloat32 c\n"
)
_SRV_IDL_DEPS = (
    f"{SEPARATOR}\nSRV: my_srvs/srv/ComplexSrvIdl\n"
    "my_srvs/BasicIdl req\n---\nmy_srvs/BasicIdl resp\n"
    f"\n{SEPARATOR}\nMSG: my_srvs/BasicIdl\n"
    f"\n{SEPARATOR}\nIDL: my_srvs/BasicIdl\n"
    "module my_srvs {\n  module msg {\n    struct BasicIdl {\n        float x;\n    };\n  };\n};\n"
)


@pytest.mark.parametrize(
    ("service", "text", "encoding", "field"),
    [
        ("my_srvs/srv/ComplexSrvMsg", _SRV_MSG_DEPS, "ros2msg", ("c", "float32")),
        ("my_srvs/srv/ComplexSrvIdl", _SRV_IDL_DEPS, "ros2idl", ("x", "float32")),
    ],
    ids=["msg-deps", "idl-deps"],
)
def test_rosbag2_jazzys_srv_layout_reads_back(
    service: str, text: str, encoding: str, field: tuple[str, str]
) -> None:
    """It was read as a .msg named ComplexSrvMsg_Event, which rosidl refuses."""
    message, types = resolve_definition(f"{service}_Event", text, encoding)
    assert [f.name for f in message.fields] == ["info", "request", "response"]
    request = types.get(f"{service}_Request")
    assert [f.name for f in request.fields] == ["req"]
    nested = types.get(request.fields[0].type.element.name)
    assert [(f.name, f.type.element.name) for f in nested.fields] == [field]


def test_a_service_event_in_rosbag2s_layout_needs_no_installed_service(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Only service_msgs (which the event's info field needs) is installed."""
    from pyconnect.typesys import definition_text

    text = installed_definition("rcl_interfaces/srv/GetParameters_Event")
    installed = installed_packages()
    only = {"service_msgs": installed["service_msgs"], "builtin_interfaces": installed["builtin_interfaces"]}  # fmt: skip
    monkeypatch.setattr(definition_text, "installed_packages", lambda: only)
    message, types = resolve_definition("rcl_interfaces/srv/GetParameters_Event", text, "ros2msg")
    response = types.get(message.fields[2].type.element.name)
    assert response.nested_types == ("rcl_interfaces/msg/ParameterValue",)
    assert message.type_hash == installed_type_hash("rcl_interfaces/srv/GetParameters_Event")


def test_a_type_named_like_a_stand_in_keeps_its_name() -> None:
    text = (
        "x_msgs/PyconnectPart0 a\nx_msgs/action/A_Result b\nx_msgs/PyconnectPart1 c\n"
        f"{SEPARATOR}\nMSG: x_msgs/PyconnectPart0\nint8 p0\n"
        f"{SEPARATOR}\nMSG: x_msgs/action/A_Result\nint8 r\n"
        f"{SEPARATOR}\nMSG: x_msgs/PyconnectPart1\nint8 p1\n"
    )
    message, types = resolve_definition("x_msgs/action/A_Goal", text, "ros2msg")
    assert message.nested_types == (
        "x_msgs/msg/PyconnectPart0", "x_msgs/action/A_Result", "x_msgs/msg/PyconnectPart1",
    )  # fmt: skip
    fields = {name: [f.name for f in types.get(name).fields] for name in message.nested_types}
    assert list(fields.values()) == [["p0"], ["r"], ["p1"]]
