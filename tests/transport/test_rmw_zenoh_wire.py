"""A raw zenoh session sees a peer exactly as rmw_zenoh (Jazzy) would: keys, CDR, attachment, tokens.

The expected formats are rmw_zenoh's (see pyconnect.transport.rmw_zenoh_keys for the source
files); the payload is checked with rclpy's own deserializer.
"""

from __future__ import annotations

import queue
import struct
import time

import xxhash
import zenoh
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState
from zenoh.ext import Int64, UInt8, z_serialize

from pyconnect.transport import rmw_zenoh_keys as keys
from tests.transport.conftest import PeerFactory, read_zenoh_attachment, zenoh_attachment

JOINT_STATE_HASH = "RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e"
SET_BOOL_HASH = "RIHS01_abe9e4bb6b41b40e6789712c00ec8871923e089af3f667a79992a428cff2da0a"


def raw_session(locator: str) -> zenoh.Session:
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("connect/endpoints", f'["{locator}"]')
    return zenoh.open(config)


def test_samples_keys_payload_attachment_and_tokens(make_peer: PeerFactory, locator: str) -> None:
    peer = make_peer("vision", domain_id=44)
    pub = peer.add_agent(conn_name="joints", conn_type="pub", data_interface=JointState)
    peer.add_agent(
        conn_name="/arm/enable",
        conn_type="service_server",
        data_interface="std_srvs/srv/SetBool",
        response_func=lambda r: {"success": True},
    )
    session = raw_session(locator)
    samples: queue.Queue[zenoh.Sample] = queue.Queue()
    key = f"44/joints/sensor_msgs::msg::dds_::JointState_/{JOINT_STATE_HASH}"
    subscriber = session.declare_subscriber(key, samples.put)
    try:
        deadline = time.monotonic() + 30
        # The raw subscriber declares no token: wait until zenoh matches it.
        while not pub.matched and time.monotonic() < deadline:
            time.sleep(0.01)
        before = time.time_ns()
        pub.send({"elbow": {"position": 0.5, "velocity": 1.0, "effort": -2.0}})
        pub.send({"elbow": {"position": 0.25, "velocity": 0.0, "effort": 0.0}})
        first, second = samples.get(timeout=30), samples.get(timeout=30)

        assert str(first.key_expr) == key
        msg = deserialize_message(first.payload.to_bytes(), JointState)
        assert list(msg.name) == ["elbow"]
        assert list(msg.position) == [0.5]
        assert list(msg.effort) == [-2.0]
        assert first.payload.to_bytes()[:4] == b"\x00\x01\x00\x00"  # CDR little-endian header

        token = pub.token_key
        assert token == (
            f"@ros2_lv/44/{peer.zid}/0/1/MP/%/%/vision/%joints/"
            f"sensor_msgs::msg::dds_::JointState_/{JOINT_STATE_HASH}/::,10:,:,:,,"
        )
        digest = xxhash.xxh3_128_intdigest(token.encode())
        gid = struct.pack("<QQ", digest & (2**64 - 1), digest >> 64)
        assert first.attachment is not None and second.attachment is not None
        sequence, stamp, sent_gid = read_zenoh_attachment(first.attachment.to_bytes())
        assert (sequence, sent_gid) == (1, gid)
        assert before <= stamp <= time.time_ns()
        assert read_zenoh_attachment(second.attachment.to_bytes())[0] == 2
        # The same bytes zenoh's own serializer writes for (int64, int64, std::array<uint8_t,
        # 16>): zenoh-cpp writes a std::array as a sequence, its length first (a Python list).
        layout = (Int64(sequence), Int64(stamp), [UInt8(b) for b in gid])
        assert z_serialize(layout).to_bytes() == first.attachment.to_bytes()

        expected = {
            f"@ros2_lv/44/{peer.zid}/0/0/NN/%/%/vision",
            token,
            f"@ros2_lv/44/{peer.zid}/0/2/SS/%/%/vision/%arm%enable/"
            f"std_srvs::srv::dds_::SetBool_/{SET_BOOL_HASH}/::,10:,:,:,,",
        }
        seen: queue.Queue[str] = queue.Queue()
        watcher = session.liveliness().declare_subscriber(
            "@ros2_lv/44/**", lambda s: seen.put(str(s.key_expr)), history=True
        )
        tokens: set[str] = set()
        while tokens != expected:
            tokens.add(seen.get(timeout=30))
            assert tokens <= expected
        watcher.undeclare()
    finally:
        subscriber.undeclare()
        session.close()


def test_a_service_answers_a_raw_query_as_rmw_zenoh_does(
    make_peer: PeerFactory, locator: str
) -> None:
    peer = make_peer("robot", domain_id=44)
    peer.add_agent(
        conn_name="enable",
        conn_type="service_server",
        data_interface="std_srvs/srv/SetBool",
        response_func=lambda r: {"success": r["data"], "message": "done"},
    )
    session = raw_session(locator)
    try:
        from rclpy.serialization import serialize_message
        from std_srvs.srv import SetBool

        key = f"44/enable/std_srvs::srv::dds_::SetBool_/{SET_BOOL_HASH}"
        client_gid = bytes(range(16))
        request = serialize_message(SetBool.Request(data=True))
        server_seen: queue.Queue[str] = queue.Queue()
        watcher = session.liveliness().declare_subscriber(
            "@ros2_lv/44/*/*/*/SS/**", lambda s: server_seen.put(str(s.key_expr)), history=True
        )
        server_seen.get(timeout=30)  # the queryable is declared before its token
        watcher.undeclare()
        replies = session.get(
            key,
            payload=request,
            attachment=zenoh_attachment(7, time.time_ns(), client_gid),
            target=zenoh.QueryTarget.ALL_COMPLETE,
            timeout=30,
        )
        (sample,) = [reply.ok for reply in replies if reply.ok is not None]
        assert str(sample.key_expr) == key
        response = deserialize_message(sample.payload.to_bytes(), SetBool.Response)
        assert (response.success, response.message) == (True, "done")
        assert sample.attachment is not None
        sequence, _stamp, gid = read_zenoh_attachment(sample.attachment.to_bytes())
        assert (sequence, gid) == (7, client_gid)
    finally:
        session.close()


def test_key_helpers_follow_rmw_zenoh() -> None:
    assert keys.data_key(0, "/robot/cmd_vel/", "geometry_msgs/msg/Twist", "RIHS01_x") == (
        "0/robot/cmd_vel/geometry_msgs::msg::dds_::Twist_/RIHS01_x"
    )
    assert keys.qos_chunk() == "::,10:,:,:,,"
    assert keys.qos_chunk(reliability="best_effort", durability="transient_local", depth=42) == (
        "2:1:,:,:,:,,"
    )
    assert keys.ros_type_name("std_srvs::srv::dds_::SetBool_") == "std_srvs/srv/SetBool"
    parsed = keys.parse_token(
        "@ros2_lv/3/abc/0/4/MS/%/%ns/node/%ns%scan/"
        "sensor_msgs::msg::dds_::LaserScan_/"
        "RIHS01_64c191398013af96509d518dac71d5164f9382553fce5c1f8cca5be7924bd828/::,10:,:,:,,"
    )
    assert parsed is not None
    assert (parsed.kind, parsed.namespace, parsed.name, parsed.type_name) == (
        "MS",
        "/ns",
        "/ns/scan",
        "sensor_msgs/msg/LaserScan",
    )
    assert keys.parse_token("@ros2_lv/3/abc") is None


def test_gaps_in_a_publishers_sequence_numbers_are_counted(
    make_peer: PeerFactory, locator: str
) -> None:
    peer = make_peer("listener", domain_id=44)
    sub = peer.add_agent(conn_name="count", conn_type="sub", data_interface="std_msgs/msg/Int32")
    session = raw_session(locator)
    try:
        key = sub._subscriber.key_expr  # 44/count/*/*: publish on the concrete key
        concrete = str(key).replace("*/*", f"std_msgs::msg::dds_::Int32_/{sub.type_hash}")
        publisher = session.declare_publisher(concrete)
        from pyconnect.codecs import wire

        deadline = time.monotonic() + 30
        while not bool(getattr(publisher.matching_status, "matching", False)):
            assert time.monotonic() < deadline
            time.sleep(0.01)
        gid = bytes(16)
        for sequence in (1, 2, 5, 6):
            publisher.put(
                wire.encode(sequence, "std_msgs/msg/Int32"),
                attachment=zenoh_attachment(sequence, time.time_ns(), gid),
            )
        while sub.message_count < 4:
            assert time.monotonic() < deadline
            time.sleep(0.01)
        assert sub.get() == 6
        assert sub.dropped_count == 2
    finally:
        session.close()
