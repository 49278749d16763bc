"""A recorder's raw subscription to one topic that keeps hearing every publisher, late ones too.

``node.record()`` and ``pyconnect bag record`` subscribe once a publisher of the topic is
known, with the QoS that hears all publishers known then (pyconnect.ros.recording_qos). A
publisher that appears later may offer less: best effort, which a reliable reader never hears,
or volatile, which a transient-local reader never hears. rosbag2 warns then that "messages from
this new publisher will not be recorded"; here the reader's incompatible-QoS event re-creates
it with the QoS that hears every publisher now known (as a sensor ``sub`` agent switches,
pyconnect.ros.sensor_subscription), and says so once in the log.

The new reader is created first; the old one is destroyed only once the new one has matched as
many publishers, so nothing from a publisher heard before is lost while the new reader is being
discovered; in that short overlap a message may be written twice. (Telling the copies apart
needs each message's ``MessageInfo``, which the agents' executor, rclpy's C++
``EventsExecutor``, does not pass to a raw subscription: "SystemError: null argument".)
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import contextlib
import threading
from collections.abc import Callable
from typing import Any

from rclpy.callback_groups import CallbackGroup
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.qos import (
    DurabilityPolicy,
    QoSPolicyKind,
    QoSProfile,
    ReliabilityPolicy,
    qos_policy_name_from_kind,
)

from pyconnect.ros.recording_qos import RECORD_DEPTH, recording_qos


class RecordingSubscription:
    """One topic's raw subscription of a recording; ``write(cdr)`` gets each message once."""

    def __init__(
        self,
        ros_node: Any,
        *,
        msg_class: type,
        topic: str,
        write: Callable[[bytes], None],
        callback_group: CallbackGroup | None = None,
    ) -> None:
        self._node = ros_node
        self._msg_class = msg_class
        self._topic = topic
        self._write = write
        self._group = callback_group
        self._lock = threading.Lock()
        self._closed = False
        self._matched = 0
        self._retiring: Any = None
        self._retiring_matched = 0
        self.notes: list[str] = []
        """What each re-subscription changed, as logged."""
        with self._lock:
            publishers = ros_node.get_publishers_info_by_topic(topic)
            self.subscription: Any = self._create(recording_qos(publishers))

    @property
    def qos(self) -> QoSProfile:
        """The QoS of the current reader."""
        profile: QoSProfile = self.subscription.qos_profile
        return profile

    def _create(self, qos: QoSProfile) -> Any:
        """A new reader with ``qos`` (called with the lock held)."""
        subscription: Any = None

        def matched(status: Any) -> None:
            self._on_matched(subscription, int(status.current_count))

        events = SubscriptionEventCallbacks(incompatible_qos=self._on_incompatible, matched=matched)
        subscription = self._node.create_subscription(
            self._msg_class,
            self._topic,
            self._write,
            qos,
            callback_group=self._group,
            event_callbacks=events,
            raw=True,
        )
        return subscription

    def _on_matched(self, subscription: Any, count: int) -> None:
        with self._lock:
            if subscription is not self.subscription:
                return
            self._matched = count
            old = self._retiring
            if old is None or count < self._retiring_matched:
                return
            self._retiring = None
            self._node.destroy_subscription(old)

    def _on_incompatible(self, status: Any) -> None:
        kind = QoSPolicyKind(status.last_policy_kind)
        if kind not in (QoSPolicyKind.RELIABILITY, QoSPolicyKind.DURABILITY):
            # What rclpy's default handler says, which passing our own handler replaces.
            self._node.get_logger().warning(
                f"New publisher discovered on topic '{self._topic}', offering incompatible QoS. "
                "No messages will be received from it. Last incompatible policy: "
                f"{qos_policy_name_from_kind(kind)}"
            )
            return
        with self._lock:
            if self._closed:
                return
            current = self.qos
            wanted = recording_qos(self._node.get_publishers_info_by_topic(self._topic))
            best_effort = kind == QoSPolicyKind.RELIABILITY or ReliabilityPolicy.BEST_EFFORT in (
                wanted.reliability,
                current.reliability,
            )
            volatile = kind == QoSPolicyKind.DURABILITY or DurabilityPolicy.VOLATILE in (
                wanted.durability,
                current.durability,
            )
            qos = QoSProfile(
                depth=RECORD_DEPTH,
                reliability=(
                    ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE
                ),
                durability=(
                    DurabilityPolicy.VOLATILE if volatile else DurabilityPolicy.TRANSIENT_LOCAL
                ),
            )
            if (qos.reliability, qos.durability) == (current.reliability, current.durability):
                return
            old, old_matched = self.subscription, self._matched
            if self._retiring is not None:  # a switch before this one still overlaps: end it
                self._node.destroy_subscription(self._retiring)
            self.subscription = self._create(qos)
            self._matched = 0
            if old_matched:
                self._retiring, self._retiring_matched = old, old_matched
            else:
                self._retiring = None
                self._node.destroy_subscription(old)
            note = (
                f"recording {self._topic}: a publisher offering "
                f"{qos_policy_name_from_kind(kind).lower()} this reader could not hear appeared; "
                f"re-subscribed {qos.reliability.name.lower()}, {qos.durability.name.lower()}"
            )
            self.notes.append(note)
        self._node.get_logger().info(note)

    def close(self) -> None:
        """Destroy the readers (idempotent; the node may be destroyed already)."""
        with self._lock:
            self._closed = True
            readers, self._retiring = (self.subscription, self._retiring), None
        for reader in readers:
            if reader is not None:
                with contextlib.suppress(Exception):  # the node is gone, its readers with it
                    self._node.destroy_subscription(reader)
