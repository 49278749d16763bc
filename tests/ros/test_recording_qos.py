"""What a recorder stores of a topic's publishers: their type's RIHS01 hash, as rosbag2 does."""

from __future__ import annotations

import pytest
from rclpy.topic_endpoint_info import TopicEndpointInfo, TopicEndpointTypeEnum
from rclpy.type_hash import TypeHash

from pyconnect.ros.recording_qos import offered_type_hash

ONE = TypeHash(version=1, value=bytes(range(32)))
TWO = TypeHash(version=1, value=bytes(32))
NONE = TypeHash(version=0)  # what an RMW that sends no hash gives
ONE_TEXT = "RIHS01_" + bytes(range(32)).hex()


def _publisher(type_hash: TypeHash, msg_type: str = "std_msgs/msg/String") -> TopicEndpointInfo:
    return TopicEndpointInfo(
        node_name="talker",
        topic_type=msg_type,
        topic_type_hash=type_hash,
        endpoint_type=TopicEndpointTypeEnum.PUBLISHER,
    )


@pytest.mark.parametrize(
    ("hashes", "stored"),
    [
        ([ONE], ONE_TEXT),
        ([ONE, ONE], ONE_TEXT),
        ([NONE, ONE], ONE_TEXT),  # one gives none: the others say what the messages are
        ([ONE, TWO], ""),  # they disagree: which one a message was written with is unknown
        ([NONE], ""),
        ([TypeHash()], ""),  # rclpy's default: no hash at all
        ([], ""),
    ],
)
def test_the_publishers_hash_when_they_agree_else_none(hashes: list[TypeHash], stored: str) -> None:
    publishers = [_publisher(type_hash) for type_hash in hashes]
    assert offered_type_hash(publishers, "std_msgs/msg/String") == stored
    assert offered_type_hash(publishers, "std_msgs/String") == stored  # the short name too


def test_publishers_of_another_type_are_left_out() -> None:
    """The recorder's subscription never hears them: their hash says nothing of the messages."""
    publishers = [_publisher(ONE), _publisher(TWO, "std_msgs/msg/Int32")]
    assert offered_type_hash(publishers, "std_msgs/msg/String") == ONE_TEXT
    assert offered_type_hash(publishers, "std_msgs/msg/Int32") == "RIHS01_" + bytes(32).hex()
