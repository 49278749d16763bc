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

The switch runs on a thread of its own, not in the event's callback: the graph query, the new
reader and above all the log line (rclpy's logger looks its caller's source up: 30-70 ms) would
stall the executor meanwhile, and the old reader's keep-last queue would drop a fast reliable
publisher's messages (5-27 in a row of a 500 Hz Imu). The new reader is created while the old
one keeps being taken, then swapped in under the lock; its callback is watched as the first
reader's is (pyconnect.ros.callback_watch), so a slow or blocking handler still hands the node
to the elastic executor and keeps its agent's group. The old reader is destroyed once the new
one has matched as many publishers as the old one is matched with then (its own ``matched``
events keep that count live: a publisher that leaves meanwhile lowers it), or after
``MAX_OVERLAP`` seconds at most; so nothing from a publisher heard before is lost while the new
reader is being discovered (in that short overlap a message may arrive twice: telling the
copies apart needs each message's ``MessageInfo``, which rclpy's C++ ``EventsExecutor`` does not
give a raw subscription).

Losses: every reader also registers the ``message_lost`` event (DDS saw a gap: a best-effort
sample that went missing on the way, or one the writer's keep-last history dropped before the
reader had it), so a reader that loses messages says so: ``lost_count`` sums the events'
``total_count_change`` over all the readers, switches included, and the first loss is logged
once (``loss_text``). Nothing runs per message for it.

Names: rclpy applies the node's remap rules to every name it is given, the graph queries' too,
so the reader is made, and re-made, from the name as given, never from the resolved one (which
``-r left:=right -r right:=left`` would remap a second time).
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Callable
from typing import Any

from rclpy.callback_groups import CallbackGroup
from rclpy.event_handler import SubscriptionEventCallbacks, UnsupportedEventTypeError
from rclpy.qos import (
    DurabilityPolicy,
    QoSPolicyKind,
    QoSProfile,
    ReliabilityPolicy,
    qos_policy_name_from_kind,
)

from pyconnect.ros.callback_watch import watch_new_entities
from pyconnect.ros.qos import matching_qos

_RELAXABLE = (QoSPolicyKind.RELIABILITY, QoSPolicyKind.DURABILITY)

MAX_OVERLAP = 10.0
"""Seconds the old reader is kept at most beside the new one, matched or not (no duplicates for
good when a count never evens out); discovery of a known publisher takes milliseconds."""

_JOIN_TIMEOUT = 5.0
"""Seconds ``close()`` waits for a switch under way (it only creates or destroys a reader)."""


class _Reader:
    """One rclpy subscription of the topic and how many publishers it is matched with now."""

    __slots__ = ("matched", "subscription")

    def __init__(self) -> None:
        self.subscription: Any = None
        self.matched = 0


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
        self._lock = threading.Condition(threading.Lock())
        """Guards the readers; the switch thread waits on it for requests and the overlap."""
        self._closed = False
        self._retiring: list[_Reader] = []
        """Previous readers, each kept until the current one has matched as many publishers."""
        self._overlap_ends = 0.0
        """When (``time.monotonic()``) the retiring readers go, matched or not."""
        self._relax: set[QoSPolicyKind] = set()
        """Policies incompatible-QoS events named that the switch thread has not looked at."""
        self._switcher: threading.Thread | None = None
        self.notes: list[str] = []
        """What each switch changed, as logged."""
        self.switched = threading.Event()
        """Set once the reader was re-created with a more relaxed QoS."""
        self.lost_count = 0
        """Messages DDS reported lost before they reached a reader of the topic (its
        ``message_lost`` events), every reader it had counted."""
        with self._lock:
            chosen = matching_qos(ros_node.get_publishers_info_by_topic(topic), depth=1)
            self._reader = self._create(self.profile(chosen.reliability, chosen.durability))
        self.topic: str = self.subscription.topic_name

    def profile(self, reliability: ReliabilityPolicy, durability: DurabilityPolicy) -> QoSProfile:
        """The reader's profile for ``reliability`` and ``durability``."""
        raise NotImplementedError

    def switch_text(self, old: QoSProfile, new: QoSProfile) -> str:
        """The log line saying the reader switched from ``old`` to ``new``."""
        raise NotImplementedError

    def loss_text(self, lost: int) -> str:
        """The warning logged at the first loss, ``lost`` messages lost so far."""
        raise NotImplementedError

    @property
    def subscription(self) -> Any:
        """The current rclpy reader (replaced when the QoS switches)."""
        return self._reader.subscription

    @property
    def matched(self) -> int:
        """Publishers the current reader is matched with (its ``matched`` events)."""
        return self._reader.matched

    @property
    def qos(self) -> QoSProfile:
        """The QoS of the current reader."""
        profile: QoSProfile = self.subscription.qos_profile
        return profile

    def _create(self, qos: QoSProfile) -> _Reader:
        """A new reader with ``qos``, its callback watched (pyconnect.ros.callback_watch)."""
        reader = _Reader()

        def matched(status: Any) -> None:
            self._on_matched(reader, int(status.current_count))

        events = SubscriptionEventCallbacks(
            incompatible_qos=self._on_incompatible,
            matched=matched,
            message_lost=self._on_message_lost,
        )
        reader.subscription = create_counting_losses(
            self._node,
            self._msg_class,
            self._name,
            self._callback,
            qos,
            callback_group=self._group,
            event_callbacks=events,
            raw=self._raw,
        )
        # At once, as add_agent does for an agent's first reader: a message the executor took
        # before this line ran unwatched (which only delays its hand-off to the idle check).
        watch_new_entities(self._node)
        return reader

    def _on_matched(self, reader: _Reader, count: int) -> None:
        with self._lock:
            reader.matched = count
            self._retire_caught_up()

    def _retire_caught_up(self) -> None:
        """Destroy the retiring readers the current one has caught up with (lock held)."""
        for old in [old for old in self._retiring if old.matched <= self._reader.matched]:
            self._retiring.remove(old)
            self._node.destroy_subscription(old.subscription)
        if not self._retiring:
            self._lock.notify_all()

    def _on_message_lost(self, status: Any) -> None:
        change = int(status.total_count_change)
        with self._lock:  # the old and the new reader's events may run on two threads
            first = self.lost_count == 0 and change > 0
            self.lost_count += change
            lost = self.lost_count
        if first:  # once: a reader that loses messages loses many, one line says it
            self._node.get_logger().warning(self.loss_text(lost))

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
            self._relax.add(kind)
            self._lock.notify_all()
            if self._switcher is None:
                self._switcher = threading.Thread(
                    target=self._switch_loop, name="pyconnect-qos-switch", daemon=True
                )
                self._switcher.start()

    def _switch_loop(self) -> None:
        """The switch thread: re-create the reader per request, then end the overlap."""
        with self._lock:
            try:
                while not self._closed:
                    if self._relax:
                        kinds, self._relax = self._relax, set()
                        self._lock.release()
                        try:
                            self._switch(kinds)
                        except Exception as error:  # this thread ends: nothing above reports
                            if not self._closed:  # else the node went away meanwhile: no news
                                self._node.get_logger().error(
                                    f"{self.topic}: could not re-create the subscription with "
                                    f"the QoS its publishers need: {error!r}"
                                )
                        finally:
                            self._lock.acquire()
                    elif not self._retiring:
                        return
                    elif (left := self._overlap_ends - time.monotonic()) > 0:
                        self._lock.wait(left)
                    else:  # a count that never evens out must not mean duplicates for good
                        for old in self._retiring:
                            self._node.destroy_subscription(old.subscription)
                        self._retiring.clear()
            finally:
                self._switcher = None

    def _switch(self, kinds: set[QoSPolicyKind]) -> None:
        """Re-create the reader with what ``kinds`` and the graph need (lock not held)."""
        current = self.qos
        # The graph knows the new publisher by now; the event names one policy only.
        wanted = matching_qos(self._node.get_publishers_info_by_topic(self._name), depth=1)
        best_effort = QoSPolicyKind.RELIABILITY in kinds or (
            ReliabilityPolicy.BEST_EFFORT in (wanted.reliability, current.reliability)
        )
        volatile = QoSPolicyKind.DURABILITY in kinds or (
            DurabilityPolicy.VOLATILE in (wanted.durability, current.durability)
        )
        reliability = ReliabilityPolicy.BEST_EFFORT if best_effort else current.reliability
        durability = DurabilityPolicy.VOLATILE if volatile else current.durability
        if (reliability, durability) == (current.reliability, current.durability):
            return
        # The old reader keeps being taken meanwhile: nothing waits for this thread.
        reader = self._create(self.profile(reliability, durability))
        with self._lock:
            if self._closed:
                self._node.destroy_subscription(reader.subscription)
                return
            self._retiring.append(self._reader)
            self._reader = reader
            self._overlap_ends = time.monotonic() + MAX_OVERLAP
            self._retire_caught_up()
            note = self.switch_text(current, reader.subscription.qos_profile)
            self.notes.append(note)
        self._node.get_logger().info(note)
        self.switched.set()

    def close(self) -> None:
        """Destroy the readers (idempotent; the node may be destroyed already)."""
        with self._lock:
            self._closed = True
            self._lock.notify_all()
            switcher = self._switcher
        if switcher is not None and switcher is not threading.current_thread():
            switcher.join(_JOIN_TIMEOUT)  # a reader it creates now, it destroys itself
        with self._lock:
            readers, self._retiring = [self._reader, *self._retiring], []
        for reader in readers:
            with contextlib.suppress(Exception):  # the node is gone, its readers with it
                self._node.destroy_subscription(reader.subscription)


def _losses_deadlock() -> bool:
    """Whether taking ``message_lost`` events can deadlock this process's rmw (Fast DDS)."""
    from rclpy.utilities import get_rmw_implementation_identifier

    return get_rmw_implementation_identifier().startswith("rmw_fastrtps")


def create_counting_losses(
    ros_node: Any,
    msg_class: type,
    topic: str,
    callback: Callable[[Any], None],
    qos: QoSProfile,
    *,
    callback_group: CallbackGroup | None,
    event_callbacks: SubscriptionEventCallbacks,
    raw: bool,
) -> Any:
    """``ros_node.create_subscription``, its ``message_lost`` event dropped on an rmw without it
    and on Fast DDS.

    rclpy leaves out the events an rmw does not support, except ``message_lost``: it raises
    ``UnsupportedEventTypeError`` (after destroying the new subscription). Elsewhere a
    subscription that cannot count its losses still beats none. Fast DDS (Jazzy's default)
    has the event but deadlocks on it: its listener thread holds the reader's lock and waits
    for the event's (``RMWSubscriptionEvent::update_sample_lost``) while taking the event holds
    the event's and waits for the reader's (``get_sample_lost_status``); a 1 kHz stream that
    lost samples froze a node's executor for good (seen in ``make bench``, 2026-11-27).
    """
    if event_callbacks.message_lost is not None and _losses_deadlock():
        event_callbacks.message_lost = None

    def create() -> Any:
        return ros_node.create_subscription(
            msg_class,
            topic,
            callback,
            qos,
            callback_group=callback_group,
            event_callbacks=event_callbacks,
            raw=raw,
        )

    try:
        return create()
    except UnsupportedEventTypeError:
        if event_callbacks.message_lost is None:
            raise
        event_callbacks.message_lost = None
        return create()
