"""A sensor subscription that follows its publishers: reliable, unless one of them is best effort.

Why: on stock Fast DDS a best-effort reader loses about half of the 640x480 frames and every
1080p frame of a closed loop (UDP fragments; bench/sensor_qos.py), while a reliable reader gets
them all; but a reliable reader never matches a best-effort writer (the classic "no images
arrive" with best-effort camera and lidar drivers). So the subscription starts reliable when
every publisher it sees is reliable (or none is there yet) and best effort when one is best
effort, and transient local when every one of them is (a latched ``CameraInfo``): the rule of
ROS 2's "best available" QoS, which rmw applies once, at creation. When a publisher it cannot
hear shows up later, the reader is re-created, once per relaxed policy, and the log says what
changed (pyconnect.ros.following_subscription), as it says when frames start going missing
(``lost_count``, the ``message_lost`` events of its readers).
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rclpy.callback_groups import CallbackGroup
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from pyconnect.ros.following_subscription import FollowingSubscription
from pyconnect.ros.qos import SENSOR_DATA


class SensorSubscription(FollowingSubscription):
    """Owns the rclpy subscription of one sensor ``sub`` agent and relaxes its QoS."""

    def __init__(
        self,
        ros_node: Any,
        *,
        msg_class: type,
        topic: str,
        callback: Callable[[Any], None],
        raw: bool,
        callback_group: CallbackGroup,
        describe: str,
    ) -> None:
        self._describe = describe
        super().__init__(
            ros_node,
            msg_class=msg_class,
            topic=topic,
            callback=callback,
            raw=raw,
            callback_group=callback_group,
        )

    @property
    def reliability(self) -> ReliabilityPolicy:
        """The reliability of the current reader."""
        policy: ReliabilityPolicy = self.qos.reliability
        return policy

    @property
    def switch_note(self) -> str | None:
        """The line logged when the subscription first switched; None before."""
        return self.notes[0] if self.notes else None

    def profile(self, reliability: ReliabilityPolicy, durability: DurabilityPolicy) -> QoSProfile:
        return QoSProfile(
            depth=SENSOR_DATA.depth,
            history=HistoryPolicy.KEEP_LAST,
            reliability=reliability,
            durability=durability,
        )

    def switch_text(self, old: QoSProfile, new: QoSProfile) -> str:
        changes = []
        if old.reliability != new.reliability:
            changes.append(
                f"a best-effort publisher appeared on {self.topic}, so the subscription switched "
                "from reliable to best effort (a reliable reader never hears a best-effort "
                "writer); without pyconnect run's shared memory, large messages may now be lost "
                "on the way."
            )
        if old.durability != new.durability:
            changes.append(
                f"a volatile publisher appeared on {self.topic}, so the subscription switched "
                "from transient local to volatile (a transient-local reader never hears a "
                "volatile writer)."
            )
        return f"{self._describe}: {' '.join(changes)} Pass qos= to choose yourself."

    def loss_text(self, lost: int) -> str:
        return (
            f"{self._describe}: DDS lost {lost} message(s) on {self.topic} so far before they "
            "reached the subscription (the agent's lost_count counts on)"
        )
