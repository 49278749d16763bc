"""The registry: lookup by class and by name, parts of services and actions, user codecs."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from typing import Any

import pytest

from pyconnect import codecs
from pyconnect.codecs import ActionCodec, DictCodec, Registry, ServiceCodec
from pyconnect.errors import CodecError, CodecNotFoundError, DecodeError, PyconnectError


class UpperStringCodec:
    msg_type = "std_msgs/msg/String"
    lossless = True

    def encode(self, value: Any) -> Any:
        from std_msgs.msg import String

        return String(data=str(value).upper())

    def decode(self, msg: Any) -> Any:
        return msg.data.lower()


@pytest.mark.parametrize(
    "type_ref", ["geometry_msgs/msg/Polygon", "geometry_msgs/Polygon", "geometry_msgs.msg.Polygon"]
)
def test_lookup_by_name_and_class(type_ref: str) -> None:
    from geometry_msgs.msg import Polygon

    registry = Registry(natural=False)
    ref: object = Polygon if "." in type_ref else type_ref
    codec = registry.lookup(ref)
    assert isinstance(codec, DictCodec)
    assert codec.msg_type == "geometry_msgs/msg/Polygon"
    assert registry.lookup(Polygon()) is codec


def test_service_and_action_types_give_their_parts() -> None:
    from std_srvs.srv import SetBool
    from test_msgs.action import Fibonacci

    registry = Registry(natural=False)
    service = registry.lookup(SetBool)
    assert isinstance(service, ServiceCodec)
    assert registry.lookup("std_srvs/SetBool") is service
    assert service.request.msg_type == "std_srvs/srv/SetBool_Request"
    assert service.response.encode({"success": True, "message": "ok"}) == SetBool.Response(
        success=True, message="ok"
    )
    assert set(service.parts) == {"Request", "Response", "Event"}
    action = registry.lookup(Fibonacci)
    assert isinstance(action, ActionCodec)
    assert action.goal.encode({"order": 5}) == Fibonacci.Goal(order=5)
    assert action.feedback.decode(Fibonacci.Feedback(sequence=[1, 1])) == {"sequence": [1, 1]}
    assert registry.lookup(Fibonacci.Result).msg_type == "test_msgs/action/Fibonacci_Result"
    with pytest.raises(CodecNotFoundError, match="is a service or action"):
        registry.lookup_message(SetBool)


def test_user_codec_wins_and_conflicts_need_override() -> None:
    from std_msgs.msg import String

    registry = Registry()
    before = registry.lookup(String)
    registry.register(String, UpperStringCodec())
    assert isinstance(registry.lookup("std_msgs/String"), UpperStringCodec)
    assert registry.lookup(String) is not before
    assert registry.encode("hi", String).data == "HI"
    with pytest.raises(PyconnectError) as raised:
        registry.register("std_msgs/msg/String", UpperStringCodec())
    assert str(raised.value) == (
        "std_msgs/msg/String already has a user codec (UpperStringCodec); "
        "pass override=True to replace it"
    )
    replacement = UpperStringCodec()
    registry.register(String, replacement, override=True)
    assert registry.lookup(String) is replacement
    registry.unregister(String)
    assert not isinstance(registry.lookup(String), UpperStringCodec)


def test_registering_a_non_codec_is_refused() -> None:
    with pytest.raises(PyconnectError, match="expected a codec with msg_type"):
        Registry().register("std_msgs/msg/String", object())  # type: ignore[arg-type]


class NamedCodec:
    lossless = True

    def __init__(self, msg_type: str) -> None:
        self.msg_type = msg_type

    def encode(self, value: Any) -> Any:
        return value

    def decode(self, msg: Any) -> Any:
        return msg


def test_registering_for_a_service_or_action_type_names_its_parts() -> None:
    from std_srvs.srv import SetBool

    registry = Registry()
    with pytest.raises(CodecError) as service:
        registry.register(SetBool, NamedCodec("std_srvs/srv/SetBool_Request"))
    assert str(service.value) == (
        "register(std_srvs/srv/SetBool): a service type has no messages of its own; register "
        "the codec for one of its parts, e.g. std_srvs/srv/SetBool_Request or "
        "std_srvs/srv/SetBool_Response"
    )
    with pytest.raises(CodecError, match=r"Fibonacci_Goal or test_msgs/action/Fibonacci_Result"):
        registry.register("test_msgs/action/Fibonacci", NamedCodec("test_msgs/action/Fibonacci"))
    # Their parts are messages: a codec registered for one is the one lookups find.
    request = NamedCodec("std_srvs/srv/SetBool_Request")
    registry.register(SetBool.Request, request)
    assert registry.lookup_service(SetBool).request is request
    goal = NamedCodec("test_msgs/action/Fibonacci_Goal")
    registry.register("test_msgs/action/Fibonacci_Goal", goal)
    assert registry.lookup_action("test_msgs/action/Fibonacci").goal is goal


def test_registering_for_a_type_that_does_not_exist_is_refused() -> None:
    with pytest.raises(CodecNotFoundError) as typo:
        Registry().register("geometry_msgs/msg/Twst", NamedCodec("geometry_msgs/msg/Twst"))
    assert str(typo.value) == (
        "register(geometry_msgs/msg/Twst): no such type: not installed, not in generated/ and "
        "not registered by definition (wire.register_definition); "
        "did you mean geometry_msgs/msg/Twist?"
    )
    with pytest.raises(CodecNotFoundError, match=r"^register\(no_such_pkg/msg/Thing\): no such"):
        Registry().register("no_such_pkg/Thing", NamedCodec("no_such_pkg/msg/Thing"))
    with pytest.raises(CodecNotFoundError, match="no such type"):
        Registry().register("std_srvs/srv/SetBool_Reply", NamedCodec("std_srvs/srv/SetBool_Reply"))


def test_a_type_known_only_by_its_definition_takes_a_codec() -> None:
    from pyconnect.codecs import wire

    class Thing(NamedCodec):
        def decode(self, msg: Any) -> Any:
            return (msg.a, msg.b)

    registry = Registry()
    with pytest.raises(CodecNotFoundError, match="no such type"):
        registry.register("my_pkg/msg/Thing", Thing("my_pkg/msg/Thing"))
    wire.register_definition("my_pkg/msg/Thing", "int32 a\nstring b\n", registry=registry)
    registry.register("my_pkg/Thing", Thing("my_pkg/Thing"))
    cdr = wire.from_dict({"a": 7, "b": "x"}, "my_pkg/msg/Thing", registry=registry)
    assert wire.decode(cdr, "my_pkg/msg/Thing", registry=registry) == (7, "x")


def test_a_codec_for_another_type_is_refused() -> None:
    from sensor_msgs.msg import Image

    registry = Registry()
    with pytest.raises(CodecError) as raised:
        registry.register(Image, NamedCodec("geometry_msgs/msg/Twist"))
    assert str(raised.value) == (
        "register(sensor_msgs/msg/Image): codec NamedCodec has msg_type "
        "'geometry_msgs/msg/Twist', expected 'sensor_msgs/msg/Image' (a codec converts the "
        "messages of its own msg_type)"
    )
    # The short and the full name are the same type.
    registry.register(Image, NamedCodec("sensor_msgs/Image"))
    registry.register("sensor_msgs/Image", NamedCodec("sensor_msgs/msg/Image"), override=True)
    assert registry.lookup(Image).msg_type == "sensor_msgs/msg/Image"


def test_registries_are_isolated() -> None:
    from std_msgs.msg import String

    isolated = Registry()
    isolated.register(String, UpperStringCodec())
    assert not isinstance(codecs.default_registry.lookup(String), UpperStringCodec)
    assert not isinstance(Registry().lookup(String), UpperStringCodec)


def test_unknown_types_and_bad_names() -> None:
    with pytest.raises(CodecNotFoundError) as raised:
        Registry().lookup("no_such_pkg/msg/Thing")
    assert str(raised.value).startswith("no_such_pkg/msg/Thing: no generated codec")
    with pytest.raises(CodecNotFoundError) as bad:
        Registry().lookup("not a type")
    assert (
        str(bad.value)
        == "'not a type' is not a ROS type name: expected 'pkg/msg/Name' or 'pkg/Name'"
    )


def test_on_the_fly_codec_for_a_type_generated_lacks() -> None:
    # rosgraph_msgs is generated, so hide its generated module to force the on-the-fly path.
    from rosgraph_msgs.msg import Clock

    from pyconnect.codecs.type_code import compiled_dict_functions

    msg_class, to_dict, from_dict = compiled_dict_functions("rosgraph_msgs/msg/Clock")
    assert msg_class is Clock
    assert to_dict(from_dict({"clock": {"sec": 3}})) == {"clock": {"sec": 3, "nanosec": 0}}
    with pytest.raises(Exception) as raised:
        from_dict({"clock": {"sec": "x"}})
    assert str(raised.value) == "Clock.clock.sec: expected int (int32), got str"
    # Tracebacks through on-the-fly code show its source lines.
    import linecache

    filename = from_dict.__code__.co_filename
    assert "def rosgraph_msgs__clock_from_dict" in "".join(linecache.getlines(filename))


def _run_hidden(code: str, hidden: str) -> subprocess.CompletedProcess[str]:
    blocker = textwrap.dedent(
        f"""
        import sys
        class Block:
            def find_spec(self, name, path=None, target=None):
                if name.split('.')[0] in {hidden!r}:
                    raise ImportError('hidden: ' + name)
        sys.meta_path.insert(0, Block())
        """
    )
    return subprocess.run(
        [sys.executable, "-c", blocker + textwrap.dedent(code)],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip


def test_codecs_import_without_rclpy() -> None:
    result = _run_hidden(
        """
        import pyconnect.codecs as codecs
        assert 'rclpy' not in sys.modules
        codecs.Registry()
        print('ok')
        """,
        "('rclpy', 'sensor_msgs', 'std_msgs', 'rosidl_parser')",
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "ok"


def test_import_registers_nothing() -> None:
    # No codec is registered as a side effect of importing pyconnect modules.
    result = _run_hidden(
        """
        import pyconnect.codecs as codecs
        import pyconnect.codecs.field_checks, pyconnect.codecs.stamped
        print(len(codecs.default_registry._user))
        """,
        "()",
    )
    assert result.stdout.strip() == "0", result.stderr


def test_registering_a_codec_class_instead_of_an_instance_is_refused() -> None:
    # The runtime Codec protocol matches the class too: it was accepted, then every encode and
    # decode raised "UpperStringCodec.encode() missing 1 required positional argument".
    registry = Registry()
    with pytest.raises(PyconnectError) as raised:
        registry.register("std_msgs/msg/String", UpperStringCodec)  # type: ignore[arg-type]
    assert str(raised.value) == (
        "register(std_msgs/msg/String): expected a codec instance, got the class "
        "UpperStringCodec; did you mean UpperStringCodec()?"
    )
    assert not isinstance(registry.lookup("std_msgs/msg/String"), UpperStringCodec)


def test_registering_a_codec_whose_encode_is_not_callable_is_refused() -> None:
    codec = UpperStringCodec()
    codec.encode = "upper"  # type: ignore[assignment,method-assign]
    with pytest.raises(PyconnectError) as raised:
        Registry().register("std_msgs/msg/String", codec)
    assert str(raised.value) == (
        "register(std_msgs/msg/String): UpperStringCodec.encode: expected a method, got str"
    )


def test_unregistering_a_type_that_does_not_exist_is_refused() -> None:
    # A misspelt name was a silent no-op that left the user codec in place.
    registry = Registry()
    registry.register("std_msgs/msg/String", UpperStringCodec())
    with pytest.raises(CodecNotFoundError) as typo:
        registry.unregister("std_msgs/msg/Strng")
    assert str(typo.value) == (
        "unregister(std_msgs/msg/Strng): no such type: not installed, not in generated/ and "
        "not registered by definition (wire.register_definition); "
        "did you mean std_msgs/msg/String?"
    )
    with pytest.raises(CodecNotFoundError, match=r"^unregister\(std_msg/msg/String\): no such"):
        registry.unregister("std_msg/msg/String")
    assert isinstance(registry.lookup("std_msgs/msg/String"), UpperStringCodec)
    registry.unregister("std_msgs/msg/Int32")  # a type without a user codec: nothing to do
    registry.unregister("std_msgs/String")
    assert not isinstance(registry.lookup("std_msgs/msg/String"), UpperStringCodec)


def test_decoding_a_message_class_instead_of_a_message_says_so() -> None:
    from sensor_msgs.msg import Image

    expected = "expected a message, got the class Image; did you mean Image()?"
    for call in (codecs.decode, codecs.to_dict, lambda msg: codecs.decode(msg, stamped=True)):
        with pytest.raises(DecodeError) as raised:
            call(Image)
        assert str(raised.value) == expected


def test_the_wire_codec_of_a_service_or_action_names_its_parts() -> None:
    # It said "no such type in its installed package", though the service is installed.
    registry = Registry()
    with pytest.raises(CodecNotFoundError) as service:
        registry.wire_codec("std_srvs/srv/SetBool")
    assert str(service.value) == (
        "std_srvs/srv/SetBool is a service, not a message: only its parts go on the wire "
        "(std_srvs/srv/SetBool_Request / std_srvs/srv/SetBool_Response)"
    )
    with pytest.raises(CodecNotFoundError) as action:
        codecs.wire.encode({}, "test_msgs/action/Fibonacci", registry=registry)
    assert str(action.value) == (
        "test_msgs/action/Fibonacci is an action, not a message: only its parts go on the wire "
        "(test_msgs/action/Fibonacci_Goal / test_msgs/action/Fibonacci_Result / "
        "test_msgs/action/Fibonacci_Feedback)"
    )
    assert codecs.wire.encode({"data": True}, "std_srvs/SetBool_Request", registry=registry)
