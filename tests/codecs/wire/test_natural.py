"""Natural values straight from CDR: the registry's codecs read the wire views like messages."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message, serialize_message

from pyconnect import codecs
from pyconnect.codecs import wire
from pyconnect.codecs.natural import NATURAL_CODECS
from pyconnect.errors import EncodeError
from tests.strategies import default_packages, message_dicts

_, TYPES = default_packages()
NATURAL_TYPES = sorted(name for name in NATURAL_CODECS if name in TYPES.messages)
_SETTINGS = settings(max_examples=10, deadline=None, database=None,
                     suppress_health_check=list(HealthCheck))  # fmt: skip


def comparable(value: Any) -> Any:
    """Natural values as nested lists and dicts (NaN kept as a marker)."""
    if isinstance(value, np.ndarray):
        # bytes, not tolist(): a (10**7, 0) array is empty but would make ten million lists
        return [value.tobytes(), str(value.dtype), list(value.shape)]
    if isinstance(value, dict):
        return {key: comparable(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [comparable(item) for item in value]
    if isinstance(value, float) and math.isnan(value):
        return "NaN"
    if hasattr(value, "__dataclass_fields__"):
        return {name: comparable(getattr(value, name)) for name in value.__dataclass_fields__}
    return value


def outcome(decode: Any) -> Any:
    """The natural value, or the kind of error the natural codec raised on it."""
    try:
        return ("value", comparable(decode()))
    except Exception as error:  # the same codec runs on both sides: any error must match
        return ("error", type(error).__name__)


@pytest.mark.parametrize("full_name", NATURAL_TYPES)
@_SETTINGS
@given(st.data())
def test_wire_decode_gives_the_natural_value_of_the_message(
    full_name: str, data: st.DataObject
) -> None:
    dict_codec = codecs.default_registry.lookup_dict(full_name)
    msg = dict_codec.from_dict(data.draw(message_dicts(TYPES.get(full_name), TYPES)))
    cdr = serialize_message(msg)
    assert outcome(lambda: wire.decode(cdr, full_name)) == outcome(lambda: codecs.decode(msg))


def test_image_decodes_as_a_zero_copy_view() -> None:
    image = np.arange(2 * 4 * 3, dtype=np.uint8).reshape(2, 4, 3)
    cdr = bytearray(wire.encode(image, "sensor_msgs/msg/Image"))
    value = wire.decode(cdr, "sensor_msgs/msg/Image")
    assert (value == image).all()
    cdr[-1] = 99  # the last pixel byte: the decoded array views the buffer
    assert value[1, 3, 2] == 99


@pytest.mark.parametrize(
    ("full_name", "value"),
    [
        ("sensor_msgs/msg/JointState", {"a": {"position": 1.0, "velocity": 2.0, "effort": 3.0}}),
        ("geometry_msgs/msg/Twist", ((0.2, 0.0, 0.0), (0.0, 0.0, 0.5))),
        ("sensor_msgs/msg/Image", np.zeros((3, 5), dtype=np.uint16)),
    ],
)
def test_natural_values_encode_to_what_rclpy_reads(full_name: str, value: Any) -> None:
    cdr = wire.encode(value, full_name)
    msg = deserialize_message(cdr, codecs.default_registry.lookup_dict(full_name).msg_class)
    assert comparable(codecs.decode(msg)) == comparable(value)
    assert comparable(wire.decode(cdr, full_name)) == comparable(value)


def test_natural_false_gives_the_dict_and_an_isolated_registry_is_honoured() -> None:
    cdr = wire.encode(((1.0, 2.0, 3.0), (4.0, 5.0, 6.0)), "geometry_msgs/msg/Twist")
    as_dict = wire.decode(cdr, "geometry_msgs/msg/Twist", natural=False)
    assert as_dict["angular"] == {"x": 4.0, "y": 5.0, "z": 6.0}
    plain = codecs.Registry(natural=False)
    assert wire.decode(cdr, "geometry_msgs/msg/Twist", registry=plain) == as_dict


class TwistAsSpeed:
    """A user codec as the README shows it: msg_type, lossless, encode, decode (no to_fields)."""

    msg_type = "geometry_msgs/msg/Twist"
    lossless = False

    def encode(self, value: Any) -> Any:
        from geometry_msgs.msg import Twist

        msg = Twist()
        msg.linear.x = float(value["vx"])
        return msg

    def decode(self, msg: Any) -> Any:
        return {"vx": msg.linear.x}


def test_a_user_codec_without_to_fields_encodes_through_its_message() -> None:
    from geometry_msgs.msg import Twist

    registry = codecs.Registry()
    registry.register(Twist, TwistAsSpeed())
    cdr = wire.encode({"vx": 2.0}, "geometry_msgs/msg/Twist", registry=registry)
    assert cdr == bytes(serialize_message(TwistAsSpeed().encode({"vx": 2.0})))
    assert wire.decode(cdr, "geometry_msgs/msg/Twist", registry=registry) == {"vx": 2.0}
    # The codec's registry is the one asked, as a pub agent asks it.
    codec = codecs.default_registry.wire_codec("geometry_msgs/msg/Twist")
    assert codec.encode({"vx": 2.0}, registry=registry) == cdr


def test_mcap_recorder_writes_values_of_a_user_codec_without_to_fields(tmp_path: Any) -> None:
    from geometry_msgs.msg import Twist

    from pyconnect.record.bag_reader import open_bag
    from pyconnect.record.mcap_recorder import McapRecorder

    registry = codecs.Registry()
    registry.register(Twist, TwistAsSpeed())
    with McapRecorder(tmp_path / "a.mcap", registry=registry) as recorder:
        recorder.add_topic("/cmd", "geometry_msgs/msg/Twist")
        recorder.write_value("/cmd", {"vx": 2.0}, log_time_ns=1)
    assert recorder.messages_written == 1
    with open_bag(tmp_path / "a.mcap", registry=registry) as bag:
        assert [m.value for m in bag] == [{"vx": 2.0}]


def test_a_user_codec_encoding_another_type_is_named() -> None:
    from std_msgs.msg import String

    class Wrong(TwistAsSpeed):
        def encode(self, value: Any) -> Any:
            return String(data="x")

    registry = codecs.Registry()
    registry.register("geometry_msgs/msg/Twist", Wrong())
    with pytest.raises(EncodeError) as raised:
        wire.encode({"vx": 1.0}, "geometry_msgs/msg/Twist", registry=registry)
    assert str(raised.value) == (
        "geometry_msgs/msg/Twist: codec Wrong.encode returned String, "
        "expected a geometry_msgs/msg/Twist message"
    )
