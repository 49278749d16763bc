"""A recorder's raw subscription to one topic that keeps hearing every publisher, late ones too.

``node.record()`` and ``pyconnect bag record`` subscribe once a publisher of the topic is
known, with the QoS that hears all publishers known then (pyconnect.ros.recording_qos). A
publisher that appears later may offer less: best effort, which a reliable reader never hears,
or volatile, which a transient-local reader never hears. rosbag2 warns then that "messages from
this new publisher will not be recorded"; here the reader is re-created with the QoS that hears
every publisher now known (pyconnect.ros.following_subscription: in the moment both readers
overlap, a message may be written twice), and the log says so. Messages DDS loses before they
reach the recorder (its ``message_lost`` events) are counted in ``lost_count`` and the first
loss is logged, naming the topic: what is not in the bag is never lost silently.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from rclpy.callback_groups import CallbackGroup
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from pyconnect.ros.following_subscription import FollowingSubscription
from pyconnect.ros.recording_qos import RECORD_DEPTH


class RecordingSubscription(FollowingSubscription):
    """One topic's raw subscription of a recording; ``write(cdr)`` gets each message."""

    def __init__(
        self,
        ros_node: Any,
        *,
        msg_class: type,
        topic: str,
        write: Callable[[bytes], None],
        callback_group: CallbackGroup | None = None,
    ) -> None:
        super().__init__(
            ros_node,
            msg_class=msg_class,
            topic=topic,
            callback=write,
            raw=True,
            callback_group=callback_group,
        )

    def profile(self, reliability: ReliabilityPolicy, durability: DurabilityPolicy) -> QoSProfile:
        return QoSProfile(depth=RECORD_DEPTH, reliability=reliability, durability=durability)

    def switch_text(self, old: QoSProfile, new: QoSProfile) -> str:
        return (
            f"recording {self.topic}: a publisher it could not hear appeared; re-subscribed "
            f"{new.reliability.name.lower()}, {new.durability.name.lower()} (was "
            f"{old.reliability.name.lower()}, {old.durability.name.lower()})"
        )

    def loss_text(self, lost: int) -> str:
        return (
            f"recording {self.topic}: DDS lost {lost} message(s) so far before they reached the "
            "recorder; they are not in the bag (the recording's end counts them all)"
        )


def lost_text(lost: Mapping[str, int]) -> str:
    """``{'/b': 1, '/a': 3}`` as ``4 message(s) (/a: 3, /b: 1)``: the total, then per topic."""
    topics = ", ".join(f"{topic}: {count}" for topic, count in sorted(lost.items()))
    return f"{sum(lost.values())} message(s) ({topics})"
