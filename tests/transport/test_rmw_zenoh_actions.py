"""A raw zenoh session drives a peer's action server as an rclpy client on rmw_zenoh would.

No rmw_zenoh is installed with the wheels, so the check is on the wire: rcl_action's service and
topic names, rmw_zenoh's key expressions and tokens with the hashes rosidl installed
(``share/<pkg>/<ns>/<Name>.json``), and payloads written and read by rclpy's own serializer.
"""

from __future__ import annotations

import json
import queue
import re
import time
from pathlib import Path
from typing import Any

import zenoh
from action_msgs.msg import GoalStatusArray
from rclpy.serialization import deserialize_message, serialize_message
from test_msgs.action import Fibonacci
from unique_identifier_msgs.msg import UUID

from pyconnect.typesys.packages import installed_packages
from tests.transport.conftest import PeerFactory, read_zenoh_attachment, zenoh_attachment
from tests.transport.test_peer_actions import fibonacci
from tests.transport.test_rmw_zenoh_wire import raw_session

TIMEOUT = 30.0


def installed_hash(type_name: str) -> str:
    """The RIHS01 hash rosidl's build wrote for ``type_name`` (its own or its parent's file)."""
    package, namespace, name = type_name.split("/")
    stem = name.split("_", 1)[0]
    path: Path = installed_packages()[package].share / namespace / f"{stem}.json"
    hashes = json.loads(path.read_text(encoding="utf-8"))["type_hashes"]
    return next(h["hash_string"] for h in hashes if h["type_name"] == type_name)


def test_tokens_keys_and_payloads_of_an_action_server(make_peer: PeerFactory, locator: str) -> None:
    peer = make_peer("robot", domain_id=44)
    server = peer.add_agent(
        conn_name="fib",
        conn_type="action_server",
        data_interface="test_msgs/action/Fibonacci",
        response_func=fibonacci,
    )
    session = raw_session(locator)
    try:
        entities = {
            (
                "MP",
                "feedback",
                "test_msgs::action::dds_::Fibonacci_FeedbackMessage_",
                installed_hash("test_msgs/action/Fibonacci_FeedbackMessage"),
                "::,10:,:,:,,",
            ),
            (
                "MP",
                "status",
                "action_msgs::msg::dds_::GoalStatusArray_",
                installed_hash("action_msgs/msg/GoalStatusArray"),
                ":1:,1:,:,:,,",
            ),
            (
                "MP",
                "abort_reason",
                "diagnostic_msgs::msg::dds_::KeyValue_",
                installed_hash("diagnostic_msgs/msg/KeyValue"),
                ":1:,32:,:,:,,",
            ),
            (
                "SS",
                "send_goal",
                "test_msgs::action::dds_::Fibonacci_SendGoal_",
                installed_hash("test_msgs/action/Fibonacci_SendGoal"),
                "::,10:,:,:,,",
            ),
            (
                "SS",
                "cancel_goal",
                "action_msgs::srv::dds_::CancelGoal_",
                installed_hash("action_msgs/srv/CancelGoal"),
                "::,10:,:,:,,",
            ),
            (
                "SS",
                "get_result",
                "test_msgs::action::dds_::Fibonacci_GetResult_",
                installed_hash("test_msgs/action/Fibonacci_GetResult"),
                "::,10:,:,:,,",
            ),
        }
        expected = {f"@ros2_lv/44/{peer.zid}/0/0/NN/%/%/robot"} | {
            f"@ros2_lv/44/{peer.zid}/0/#/{kind}/%/%/robot/%fib%_action%{part}/{dds}/{type_hash}/"
            f"{qos}"
            for kind, part, dds, type_hash, qos in entities
        }
        seen: queue.Queue[str] = queue.Queue()
        watcher = session.liveliness().declare_subscriber(
            "@ros2_lv/44/**", lambda s: seen.put(str(s.key_expr)), history=True
        )
        tokens: set[str] = set()
        while tokens != expected:
            # Entity ids count per session; their order is the agent's business.
            tokens.add(re.sub(r"^(@ros2_lv/44/\w+/0)/[1-9]\d*/", r"\1/#/", seen.get(timeout=30)))
            assert tokens <= expected
        watcher.undeclare()

        def key(part: str, dds: str, type_name: str) -> str:
            return f"44/fib/_action/{part}/{dds}/{installed_hash(type_name)}"

        feedback: queue.Queue[zenoh.Sample] = queue.Queue()
        status: queue.Queue[zenoh.Sample] = queue.Queue()
        fb_key = key(
            "feedback",
            "test_msgs::action::dds_::Fibonacci_FeedbackMessage_",
            "test_msgs/action/Fibonacci_FeedbackMessage",
        )
        subscribers = [
            session.declare_subscriber(fb_key, feedback.put),
            session.declare_subscriber(
                key(
                    "status",
                    "action_msgs::msg::dds_::GoalStatusArray_",
                    "action_msgs/msg/GoalStatusArray",
                ),
                status.put,
            ),
        ]
        # The raw subscribers declare no token: wait until zenoh matches them.
        deadline = time.monotonic() + TIMEOUT
        while not (server._feedback.matched and server._status.matched):
            assert time.monotonic() < deadline
            time.sleep(0.01)
        goal_id = UUID(uuid=list(range(16)))
        request = Fibonacci.Impl.SendGoalService.Request(
            goal_id=goal_id, goal=Fibonacci.Goal(order=3)
        )
        sent = call(
            session,
            key(
                "send_goal",
                "test_msgs::action::dds_::Fibonacci_SendGoal_",
                "test_msgs/action/Fibonacci_SendGoal",
            ),
            serialize_message(request),
            sequence=1,
        )
        answer = deserialize_message(sent, Fibonacci.Impl.SendGoalService.Response)
        assert answer.accepted is True
        got = call(
            session,
            key(
                "get_result",
                "test_msgs::action::dds_::Fibonacci_GetResult_",
                "test_msgs/action/Fibonacci_GetResult",
            ),
            serialize_message(Fibonacci.Impl.GetResultService.Request(goal_id=goal_id)),
            sequence=2,
        )
        result = deserialize_message(got, Fibonacci.Impl.GetResultService.Response)
        assert result.status == 4  # SUCCEEDED
        assert list(result.result.sequence) == [0, 1, 1, 2, 3]
        for order in range(3):
            sample = feedback.get(timeout=TIMEOUT)
            assert str(sample.key_expr) == fb_key
            message = deserialize_message(sample.payload.to_bytes(), Fibonacci.Impl.FeedbackMessage)
            assert bytes(message.goal_id.uuid) == bytes(range(16))
            assert len(message.feedback.sequence) == order + 3
        statuses: list[int] = []
        while 4 not in statuses:  # accepted, executing, then succeeded
            array = deserialize_message(
                status.get(timeout=TIMEOUT).payload.to_bytes(), GoalStatusArray
            )
            assert [bytes(s.goal_info.goal_id.uuid) for s in array.status_list] == [
                bytes(range(16))
            ]
            statuses += [s.status for s in array.status_list]
        assert statuses == [1, 2, 4]
        for subscriber in subscribers:
            subscriber.undeclare()
    finally:
        session.close()


def call(session: zenoh.Session, key: str, payload: bytes, *, sequence: int) -> Any:
    """One rmw_zenoh-style service call: the response's bytes; the attachment is echoed."""
    client_gid = bytes(range(16, 32))
    replies = session.get(
        key,
        payload=payload,
        attachment=zenoh_attachment(sequence, time.time_ns(), client_gid),
        target=zenoh.QueryTarget.ALL_COMPLETE,
        timeout=TIMEOUT,
    )
    (sample,) = [reply.ok for reply in replies if reply.ok is not None]
    assert str(sample.key_expr) == key
    assert sample.attachment is not None
    echoed_sequence, _stamp, gid = read_zenoh_attachment(sample.attachment.to_bytes())
    assert (echoed_sequence, gid) == (sequence, client_gid)
    return sample.payload.to_bytes()
