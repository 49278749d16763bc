"""A sensor subscription that follows its publishers: reliable, unless one of them is best effort.

Why: on stock Fast DDS a best-effort reader loses about half of the 640x480 frames and every
1080p frame of a closed loop (UDP fragments; bench/sensor_qos.py), while a reliable reader gets
them all; but a reliable reader never matches a best-effort writer (the classic "no images
arrive" with best-effort camera and lidar drivers). So the subscription starts reliable when
every publisher it sees is reliable (or none is there yet) and best effort when one is best
effort, the rule of ROS 2's "best available" QoS (``ReliabilityPolicy.BEST_AVAILABLE``, which
rmw applies once, at creation). When a best-effort publisher shows up later, the reliable
reader's incompatible-QoS event re-creates it as best effort, once, and logs what changed.

The switch runs in the subscription's callback group (event handlers share it), so it never
overlaps the agent's message callback, on EventsExecutor and ElasticExecutor alike. The new
best-effort reader is created first; the reliable one is destroyed only once the new one has
matched as many publishers as the old one had, so no message from a reliable publisher is lost
while the new reader is being discovered (in that short overlap one may arrive twice). A
best-effort subscription never switches back: a best-effort driver that restarts must still
be heard.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

from rclpy.callback_groups import CallbackGroup
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.qos import QoSPolicyKind, ReliabilityPolicy, qos_policy_name_from_kind

from pyconnect.ros.qos import matching_reliability, sensor_subscriber_profile


class SensorSubscription:
    """Owns the rclpy subscription of one sensor ``sub`` agent and switches its reliability."""

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
        self._node = ros_node
        self._msg_class = msg_class
        self._callback = callback
        self._raw = raw
        self._group = callback_group
        self._describe = describe
        self._lock = threading.Lock()
        self._closed = False
        self._old_matched = 0
        """Publishers the reliable reader is matched with (its ``matched`` events)."""
        self._retiring: Any = None
        """The reliable reader, kept until its best-effort successor has matched as many."""
        self.switch_note: str | None = None
        """The line logged when the subscription switched to best effort; None before."""
        self.switched = threading.Event()
        # rclpy applies the node's remap rules to every name it is given (the graph query's
        # too): so the name as given, never the resolved one, which a rule such as
        # ``-r left:=right -r right:=left`` would remap a second time.
        self._name = topic
        reliability = matching_reliability(ros_node.get_publishers_info_by_topic(topic))
        self.subscription: Any = self._create(topic, reliability)
        self.topic: str = self.subscription.topic_name

    @property
    def reliability(self) -> ReliabilityPolicy:
        """The reliability of the current reader."""
        policy: ReliabilityPolicy = self.subscription.qos_profile.reliability
        return policy

    def _create(self, topic: str, reliability: ReliabilityPolicy) -> Any:
        if reliability == ReliabilityPolicy.RELIABLE:
            events = SubscriptionEventCallbacks(
                incompatible_qos=self._on_incompatible, matched=self._on_reliable_matched
            )
        else:
            events = SubscriptionEventCallbacks(matched=self._on_best_effort_matched)
        return self._node.create_subscription(
            self._msg_class,
            topic,
            self._callback,
            sensor_subscriber_profile(reliability),
            callback_group=self._group,
            event_callbacks=events,
            raw=self._raw,
        )

    def _on_reliable_matched(self, status: Any) -> None:
        self._old_matched = int(status.current_count)

    def _on_incompatible(self, status: Any) -> None:
        kind = QoSPolicyKind(status.last_policy_kind)
        if kind != QoSPolicyKind.RELIABILITY:
            # What rclpy's default handler says, which passing our own handler replaces.
            self._node.get_logger().warning(
                f"New publisher discovered on topic '{self.topic}', offering incompatible QoS. "
                "No messages will be received from it. Last incompatible policy: "
                f"{qos_policy_name_from_kind(kind)}"
            )
            return
        with self._lock:
            if self._closed or self.switch_note is not None:
                return
            old = self.subscription
            self.subscription = self._create(self._name, ReliabilityPolicy.BEST_EFFORT)
            if self._old_matched == 0:
                self._node.destroy_subscription(old)
            else:
                self._retiring = old
            self.switch_note = (
                f"{self._describe}: a best-effort publisher appeared on {self.topic}, so the "
                "subscription switched from reliable to best effort (a reliable reader never "
                "hears a best-effort writer); without pyconnect run's shared memory, large "
                "messages may now be lost on the way. Pass qos= to choose yourself."
            )
        self._node.get_logger().info(self.switch_note)
        self.switched.set()

    def _on_best_effort_matched(self, status: Any) -> None:
        with self._lock:
            old = self._retiring
            if old is None or int(status.current_count) < self._old_matched:
                return
            self._retiring = None
            self._node.destroy_subscription(old)

    def close(self) -> None:
        with self._lock:
            self._closed = True
            for subscription in (self.subscription, self._retiring):
                if subscription is not None:
                    self._node.destroy_subscription(subscription)
            self._retiring = None
