"""Raw (the default) sub and pub agents give the values of the class path, for every natural codec.

Each type gets a raw and a class ``sub`` agent and a raw and a class ``pub`` agent on one node;
hypothesis draws messages, the subscription callbacks get the serialized bytes (raw) or the
message (class), and the publishers' ``publish`` is captured: both paths must give the same
value, or fail the same way. A last test runs the raw path over DDS.
"""

from __future__ import annotations

import threading
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message, serialize_message

from pyconnect import codecs
from pyconnect.codecs.natural import NATURAL_CODECS
from pyconnect.errors import PyconnectError
from tests.codecs.wire.test_natural import comparable
from tests.codecs.wire.test_point_cloud_cdr import cloud
from tests.strategies import SENDABLE_CHARACTERS, default_packages, message_dicts

from .conftest import EVENT_TIMEOUT

_, TYPES = default_packages()
NATURAL_TYPES = sorted(name for name in NATURAL_CODECS if name in TYPES.messages)
DICT_TYPES = [
    "test_msgs/msg/BasicTypes",
    "test_msgs/msg/Arrays",
    "test_msgs/msg/Nested",
    "test_msgs/msg/Strings",
    "sensor_msgs/msg/Imu",
]
_SETTINGS = settings(max_examples=8, deadline=None, database=None,
                     suppress_health_check=list(HealthCheck))  # fmt: skip


@pytest.fixture(autouse=True)
def _publish_through_rclpy(monkeypatch: pytest.MonkeyPatch) -> None:
    """The raw pub agents publish with ``serialized_io.publish_serialized`` (rcl, through ctypes);
    the tests here replace ``publisher.publish`` to see what is sent, so they go through it."""
    from pyconnect.ros import publisher_agent

    monkeypatch.setattr(
        publisher_agent, "publish_serialized", lambda publisher, data: publisher.publish(data)
    )


def outcome(compute: Any) -> Any:
    """The comparable value, or the kind of error raised (both paths must fail alike)."""
    try:
        return ("value", comparable(compute()))
    except Exception as error:
        return ("error", type(error).__name__)


def without_stamp(fields: dict[str, Any]) -> dict[str, Any]:
    """A message dict without its header stamp (each path stamps with its own "now")."""
    header = fields.get("header")
    if isinstance(header, dict):
        return {**fields, "header": {**header, "stamp": None}}
    return fields


class Paths:
    """A raw and a class agent of each direction for one type, fed by hand (no DDS)."""

    def __init__(self, node: Any, full_name: str) -> None:
        self.msg_class = codecs.default_registry.lookup_dict(full_name).msg_class
        common = {"data_interface": full_name, "conn_name": "t"}
        self.raw_sub = node.add_agent(common, agent_name="raw_sub", conn_type="sub", raw=True)
        self.class_sub = node.add_agent(common, agent_name="class_sub", conn_type="sub", raw=False)
        self.raw_pub = node.add_agent(
            common, agent_name="raw_pub", conn_type="pub", raw=True, frame_id="cam"
        )
        self.class_pub = node.add_agent(
            common, agent_name="class_pub", conn_type="pub", frame_id="cam", raw=False
        )
        assert self.raw_sub._raw is not None
        assert self.class_sub._raw is None
        self.published: dict[str, list[Any]] = {"raw": [], "class": []}
        self.raw_pub.publisher.publish = self.published["raw"].append
        self.class_pub.publisher.publish = self.published["class"].append

    def received(self, msg: Any) -> tuple[Any, Any]:
        """What each sub delivers for ``msg`` (the raw one gets its serialized bytes)."""
        self.raw_sub.subscription.callback(serialize_message(msg))
        self.class_sub.subscription.callback(msg)
        return self.raw_sub.get(), self.class_sub.get()

    def sent(self, value: Any) -> tuple[Any, Any]:
        """The message dict each pub publishes for ``value`` (header stamp left out)."""
        raw = outcome(lambda: self._sent_dict("raw", self.raw_pub, value))
        plain = outcome(lambda: self._sent_dict("class", self.class_pub, value))
        return raw, plain

    def _sent_dict(self, path: str, agent: Any, value: Any) -> Any:
        agent.send(value)
        published = self.published[path].pop()
        if path == "raw" and value is not None:  # None (an empty type) is sent as the message
            assert isinstance(published, bytes)
            published = deserialize_message(published, self.msg_class)
        else:
            assert isinstance(published, self.msg_class)
        return without_stamp(codecs.to_dict(published))


@pytest.mark.parametrize("full_name", NATURAL_TYPES + DICT_TYPES)
def test_raw_and_class_paths_give_the_same_values(make_node: Any, full_name: str) -> None:
    paths = Paths(make_node(), full_name)
    dict_codec = codecs.default_registry.lookup_dict(full_name)

    @_SETTINGS
    @given(st.data())
    def check(data: st.DataObject) -> None:
        msg = dict_codec.from_dict(data.draw(message_dicts(TYPES.get(full_name), TYPES)))
        errors = (paths.raw_sub.error_count, paths.class_sub.error_count)
        raw, plain = paths.received(msg)
        failed = (paths.raw_sub.error_count - errors[0], paths.class_sub.error_count - errors[1])
        assert failed[0] == failed[1]  # a message one path rejects, the other rejects too
        if failed[0]:
            return
        assert comparable(raw) == comparable(plain)
        raw_sent, class_sent = paths.sent(plain)
        assert raw_sent == class_sent

    check()


def test_raw_pub_fills_the_header_like_the_class_path(make_node: Any) -> None:
    paths = Paths(make_node(), "sensor_msgs/msg/Image")
    image = np.zeros((2, 3), dtype=np.uint8)
    paths.raw_pub.send(image)
    msg = deserialize_message(paths.published["raw"].pop(), paths.msg_class)
    assert msg.header.frame_id == "cam"
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) != (0, 0)


def test_small_header_less_types_are_written_and_read_straight(make_node: Any) -> None:
    """codecs/fast_paths.py's paths: same bytes and values as the general path, same errors."""
    flat = Paths(make_node(), "std_msgs/msg/Float64MultiArray")
    assert flat.raw_pub._raw.encode_bytes is not None
    text = Paths(make_node(), "std_msgs/msg/String")
    assert text.raw_pub._raw.encode_bytes is not None
    assert text.raw_sub._raw.decode_value is not None  # decoded straight too
    assert text.received(text.msg_class(data="héllo")) == ("héllo", "héllo")
    assert flat.raw_sub._raw.decode_value is not None  # into a writable copy, as the class path
    raw_array, class_array = flat.received(flat.msg_class(data=[1.5, -2.0]))
    assert raw_array.tolist() == class_array.tolist() == [1.5, -2.0]
    assert raw_array.flags.writeable and class_array.flags.writeable
    assert Paths(make_node(), "sensor_msgs/msg/Image").raw_pub._raw.encode_bytes is None
    value = np.linspace(0.0, 1.0, 5)
    flat.raw_pub.send(value)
    sent = flat.published["raw"].pop()
    assert sent == flat.raw_pub._raw.encode(value, now=time_unused, frame_id="")[0]
    assert deserialize_message(sent, flat.msg_class).data.tolist() == value.tolist()
    with pytest.raises(PyconnectError) as refused:
        flat.raw_pub.send("not an array")
    assert str(refused.value) == (
        "agent 'raw_pub' (pub std_msgs/msg/Float64MultiArray): Float64MultiArray: expected "
        "numpy.ndarray, got str"
    )


def time_unused() -> tuple[int, int]:
    raise AssertionError("a Float64MultiArray has no header to stamp")


def test_raw_image_is_writable_like_the_class_paths(make_node: Any) -> None:
    paths = Paths(make_node(), "sensor_msgs/msg/Image")
    msg = codecs.encode(np.zeros((2, 3), dtype=np.uint8), "sensor_msgs/msg/Image")
    raw, plain = paths.received(msg)
    assert raw.flags.writeable and plain.flags.writeable
    raw[0, 0] = 7  # the user's callback may draw on the image it got


def test_raw_is_the_default_unless_a_message_is_needed(make_node: Any) -> None:
    node = make_node()
    twist = {"conn_name": "cmd", "data_interface": "geometry_msgs/msg/Twist"}
    assert node.add_agent(twist, conn_type="sub")._raw is not None
    assert node.add_agent(twist, agent_name="p", conn_type="pub")._raw is not None
    decoded = node.add_agent(twist, agent_name="d", conn_type="sub", decode_func=lambda m: m)
    assert decoded._raw is None
    stamped = node.add_agent(
        conn_name="cmd_stamped", conn_type="sub", stamped=True,
        data_interface="geometry_msgs/msg/TwistStamped",  # stamped=True needs a header
    )  # fmt: skip
    assert stamped._raw is None
    encoded = node.add_agent(
        twist, agent_name="e", conn_type="pub", encode_func=lambda data, msg: msg
    )
    assert encoded._raw is None
    with pytest.raises(PyconnectError) as refused:
        node.add_agent(twist, agent_name="r", conn_type="sub", decode_func=repr, raw=True)
    assert str(refused.value) == (
        "agent 'r' (sub geometry_msgs/msg/Twist): raw=True converts with the wire codecs; it "
        "cannot be combined with decode_func (they work on rclpy messages)"
    )


def test_a_codec_the_user_registered_gets_messages(make_node: Any) -> None:
    class Upper:
        msg_type = "std_msgs/msg/String"
        lossless = True

        def encode(self, value: str) -> Any:
            from std_msgs.msg import String

            return String(data=value.lower())

        def decode(self, msg: Any) -> str:
            return str(msg.data).upper()

    registry = codecs.Registry()
    registry.register("std_msgs/msg/String", Upper())
    node = make_node(registry=registry)
    sub = node.add_agent(conn_name="t", conn_type="sub", data_interface="std_msgs/msg/String")
    assert sub._raw is None


def test_raw_sub_reports_undecodable_bytes(make_node: Any) -> None:
    paths = Paths(make_node(), "std_msgs/msg/String")
    paths.raw_sub.subscription.callback(b"\x00\x01\x00\x00\xff\xff\xff\x7f")
    assert paths.raw_sub.error_count == 1
    assert paths.raw_sub.get() is None


def test_raw_path_over_dds(make_node: Any) -> None:
    node = make_node()
    got: dict[str, Any] = {}
    arrived = {name: threading.Event() for name in ("raw", "class")}

    def keep(path: str) -> Any:
        def on_value(value: Any) -> None:
            got[path] = value
            arrived[path].set()

        return on_value

    for path in ("raw", "class"):
        node.add_agent(
            conn_name="joints", agent_name=f"{path}_sub", conn_type="sub",
            data_interface="sensor_msgs/msg/JointState", raw=path == "raw",
            response_func=keep(path),
        )  # fmt: skip
    publisher = node.add_agent(
        conn_name="joints", conn_type="pub", data_interface="sensor_msgs/msg/JointState", raw=True
    )
    node.spin(run_thread=True)
    joints = {"elbow": {"position": 1.5, "velocity": 0.25, "effort": -2.0}}
    for _ in range(int(EVENT_TIMEOUT / 0.05)):
        publisher.send(joints)
        if all(event.wait(0.05) for event in arrived.values()):
            break
    assert got == {"raw": joints, "class": joints}


def test_raw_agents_publish_through_rcl_over_dds(
    make_node: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Across two nodes a raw pub agent publishes with ``serialized_io`` (no copy before rcl's)
    and the other node's raw sub gets the same value, writable like the class path's."""
    from pyconnect.ros import publisher_agent, serialized_io

    assert serialized_io._rcl() is not None  # the wheel's librcl, loaded by rclpy
    published: list[int] = []

    def counted_publish(publisher: Any, data: bytes) -> None:
        published.append(len(data))
        serialized_io.publish_serialized(publisher, data)

    monkeypatch.setattr(publisher_agent, "publish_serialized", counted_publish)
    receiver, sender = make_node("raw_rx"), make_node("raw_tx")
    got: list[Any] = []
    arrived = threading.Event()

    def on_image(value: Any) -> None:
        got.append(value)
        arrived.set()

    receiver.add_agent(
        conn_name="frames", conn_type="sub", data_interface="sensor_msgs/msg/Image",
        response_func=on_image, qos="default",
    )  # fmt: skip
    pub = sender.add_agent(
        conn_name="frames", conn_type="pub", data_interface="sensor_msgs/msg/Image",
        qos="default",
    )  # fmt: skip
    receiver.spin(run_thread=True)
    sender.spin(run_thread=True)
    image = (np.arange(160 * 160 * 3) % 251).astype(np.uint8).reshape(160, 160, 3)
    assert image.nbytes >= serialized_io.DIRECT_FROM_BYTES  # through rcl, not rclpy's copy
    for _ in range(int(EVENT_TIMEOUT / 0.05)):
        pub.send(image)
        if arrived.wait(0.05):
            break
    assert np.array_equal(got[0], image)
    assert got[0].flags.writeable
    assert published


def test_publish_serialized_falls_back_to_rclpy_without_rcl(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from pyconnect.ros import serialized_io

    monkeypatch.setattr(serialized_io, "_loaded", [None])
    sent: list[Any] = []

    class Publisher:
        publish = sent.append

    small, large = b"\x00\x01\x00\x00", bytes(serialized_io.DIRECT_FROM_BYTES)
    serialized_io.publish_serialized(Publisher(), small)  # small: rclpy's call, always
    serialized_io.publish_serialized(Publisher(), large)  # large, but no librcl loaded
    assert sent == [small, large]


def test_a_large_taken_message_is_made_writable_in_place(make_node: Any) -> None:
    """From ``IN_PLACE_BYTES`` the value is a view of the taken bytes (no copy), writable like
    the class path's; a small message is copied, so the bytes it came in stay as they were."""
    from pyconnect.ros.raw_path import IN_PLACE_BYTES

    paths = Paths(make_node(), "sensor_msgs/msg/Image")
    side = int((IN_PLACE_BYTES // 3) ** 0.5) + 1
    for shape, in_place in (((side, side, 3), True), ((4, 4, 3), False)):
        image = np.arange(np.prod(shape), dtype=np.uint64).astype(np.uint8).reshape(shape)
        taken = serialize_message(codecs.encode(image, "sensor_msgs/msg/Image"))
        before = bytes(bytearray(taken))
        paths.raw_sub.subscription.callback(taken)
        value = paths.raw_sub.get()
        assert np.array_equal(value, image)
        assert value.flags.writeable
        assert np.shares_memory(value, np.frombuffer(taken, np.uint8)) is in_place
        value[0, 0, 0] = 200
        assert (taken == before) is not in_place
        del taken, value


@settings(max_examples=40, deadline=None, database=None)
@given(
    count=st.sampled_from([0, 1, 3, 7, 1000]),
    layout=st.sampled_from(["xyz", "xyzrgb", "organised", "xyz64", "n3"]),
    frame_id=st.text(SENDABLE_CHARACTERS, max_size=6),  # NUL and lone surrogates: refused
    spots=st.lists(
        st.tuples(
            st.floats(0, 1, exclude_max=True), st.sampled_from([np.nan, np.inf, 3.0e38, 0.5])
        ),
        max_size=2,
    ),
)
def test_cloud_cdr_is_the_wire_codecs_bytes(
    count: int, layout: str, frame_id: str, spots: Any
) -> None:
    """A large cloud's CDR written in one pass over the points (``cloud_cdr``) is byte for byte
    what the wire codec writes, with the same exact ``is_dense``, for every alignment."""
    from pyconnect.codecs import point_cloud_cdr
    from pyconnect.ros import raw_path

    points = cloud(layout, count, spots)
    encoder = raw_path.RawEncoder(
        msg_type=raw_path.CLOUD, registry=codecs.default_registry, has_header=True,
        describe="cloud",
    )  # fmt: skip
    expected, expected_fields = encoder.encode(points, now=lambda: (3, 4), frame_id=frame_id)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(point_cloud_cdr, "IN_ONE_PASS_BYTES", 0)
        fast, fields = encoder.encode(points, now=lambda: (3, 4), frame_id=frame_id)
    assert fast == expected
    assert fields["is_dense"] is expected_fields["is_dense"]
