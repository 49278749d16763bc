"""A subscription that hears every publisher of its topic, late ones too (ROS 2's "best available").

Its QoS is chosen from the publishers known when it is created, as rmw_dds_common's
``qos_profile_get_best_available_for_subscription`` chooses: reliable unless one of them is
best effort, transient local when all of them are (so a latched message sent earlier arrives
too). rmw applies that rule once, at creation, usually before discovery has found anyone; here
a publisher that appears later offering less (best effort, which a reliable reader never hears,
or volatile, which a transient-local reader never hears) fires the reader's incompatible-QoS
event, and the reader is re-created with the QoS that hears every publisher now known, and says
so once in the log. A relaxed reader never tightens again: a best-effort driver that restarts
must still be heard.

The switch runs in the subscription's callback group (event handlers share it), so it never
overlaps the message callback, on EventsExecutor and ElasticExecutor alike. The new reader is
created first; the old one is destroyed only once the new one has matched as many publishers,
so nothing from a publisher heard before is lost while the new reader is being discovered (in
that short overlap a message may arrive twice: telling the copies apart needs each message's
``MessageInfo``, which rclpy's C++ ``EventsExecutor`` does not give a raw subscription).

Names: rclpy applies the node's remap rules to every name it is given, the graph queries' too,
so the reader is made, and re-made, from the name as given, never from the resolved one (which
``-r left:=right -r right:=left`` would remap a second time).
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

from pyconnect.ros.qos import matching_qos

_RELAXABLE = (QoSPolicyKind.RELIABILITY, QoSPolicyKind.DURABILITY)


class FollowingSubscription:
    """Owns one topic's rclpy subscription and relaxes its QoS when a publisher needs it.

    Subclasses say which profile a reader gets for a reliability and durability
    (``profile``) and what the log says when it switched (``switch_text``).
    """

    def __init__(
        self,
        ros_node: Any,
        *,
        msg_class: type,
        topic: str,
        callback: Callable[[Any], None],
        raw: bool,
        callback_group: CallbackGroup | None,
    ) -> None:
        self._node = ros_node
        self._msg_class = msg_class
        self._name = topic
        self._callback = callback
        self._raw = raw
        self._group = callback_group
        self._lock = threading.Lock()
        self._closed = False
        self._matched = 0
        """Publishers the current reader is matched with (its ``matched`` events)."""
        self._retiring: Any = None
        """The previous reader, kept until its successor has matched as many publishers."""
        self._retiring_matched = 0
        self.notes: list[str] = []
        """What each switch changed, as logged."""
        self.switched = threading.Event()
        """Set once the reader was re-created with a more relaxed QoS."""
        with self._lock:
            chosen = matching_qos(ros_node.get_publishers_info_by_topic(topic), depth=1)
            self.subscription: Any = self._create(
                self.profile(chosen.reliability, chosen.durability)
            )
        self.topic: str = self.subscription.topic_name

    def profile(self, reliability: ReliabilityPolicy, durability: DurabilityPolicy) -> QoSProfile:
        """The reader's profile for ``reliability`` and ``durability``."""
        raise NotImplementedError

    def switch_text(self, old: QoSProfile, new: QoSProfile) -> str:
        """The log line saying the reader switched from ``old`` to ``new``."""
        raise NotImplementedError

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
            self._name,
            self._callback,
            qos,
            callback_group=self._group,
            event_callbacks=events,
            raw=self._raw,
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
        if kind not in _RELAXABLE:
            # What rclpy's default handler says, which passing our own handler replaces.
            self._node.get_logger().warning(
                f"New publisher discovered on topic '{self.topic}', offering incompatible QoS. "
                "No messages will be received from it. Last incompatible policy: "
                f"{qos_policy_name_from_kind(kind)}"
            )
            return
        with self._lock:
            if self._closed:
                return
            current = self.qos
            # The graph knows the new publisher by now; the event names one policy only.
            wanted = matching_qos(self._node.get_publishers_info_by_topic(self._name), depth=1)
            best_effort = kind == QoSPolicyKind.RELIABILITY or (
                ReliabilityPolicy.BEST_EFFORT in (wanted.reliability, current.reliability)
            )
            volatile = kind == QoSPolicyKind.DURABILITY or (
                DurabilityPolicy.VOLATILE in (wanted.durability, current.durability)
            )
            reliability = ReliabilityPolicy.BEST_EFFORT if best_effort else current.reliability
            durability = DurabilityPolicy.VOLATILE if volatile else current.durability
            if (reliability, durability) == (current.reliability, current.durability):
                return
            old, old_matched = self.subscription, self._matched
            if self._retiring is not None:  # a switch before this one still overlaps: end it
                self._node.destroy_subscription(self._retiring)
            self.subscription = self._create(self.profile(reliability, durability))
            self._matched = 0
            if old_matched:
                self._retiring, self._retiring_matched = old, old_matched
            else:
                self._retiring = None
                self._node.destroy_subscription(old)
            note = self.switch_text(current, self.subscription.qos_profile)
            self.notes.append(note)
        self._node.get_logger().info(note)
        self.switched.set()

    def close(self) -> None:
        """Destroy the readers (idempotent; the node may be destroyed already)."""
        with self._lock:
            self._closed = True
            readers, self._retiring = (self.subscription, self._retiring), None
        for reader in readers:
            if reader is not None:
                with contextlib.suppress(Exception):  # the node is gone, its readers with it
                    self._node.destroy_subscription(reader)
