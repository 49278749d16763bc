"""The reader switch of pyconnect.ros.following_subscription, driven event by event on a stand-in
node: which reader is kept, which is destroyed, and when, never depends on discovery's timing."""

from __future__ import annotations

import threading
from types import SimpleNamespace
from typing import Any

import pytest
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.event_handler import QoSSubscriptionEventType, UnsupportedEventTypeError
from rclpy.qos import QoSPolicyKind, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image

from pyconnect.ros import following_subscription
from pyconnect.ros.sensor_subscription import SensorSubscription

QUICK = 5.0
"""Seconds a step with nothing to wait for may take (it takes microseconds)."""

RELIABLE = SimpleNamespace(qos_profile=QoSProfile(depth=5))
BEST_EFFORT = SimpleNamespace(
    qos_profile=QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)
)
RELIABILITY_INCOMPATIBLE = SimpleNamespace(last_policy_kind=QoSPolicyKind.RELIABILITY.value)


def matched(count: int) -> Any:
    return SimpleNamespace(current_count=count)


def lost(total: int, change: int) -> Any:
    """A ``message_lost`` event's status: the reader's total and what it adds."""
    return SimpleNamespace(total_count=total, total_count_change=change)


def message_lost_callback(subscription: Any) -> Any:
    """The callback of an rclpy subscription's one ``message_lost`` event handler (DDS cannot
    be made to lose a message on cue: tests call it with ``lost(...)``)."""
    kind = QoSSubscriptionEventType.RCL_SUBSCRIPTION_MESSAGE_LOST
    handlers = [h for h in subscription.event_handlers if h.event_type == kind]
    assert len(handlers) == 1, subscription.event_handlers
    return handlers[0].callback


class WarningsLogged:
    """A node's logger, keeping what is logged as a warning."""

    def __init__(self, logger: Any) -> None:
        self.logger = logger
        self.warnings: list[str] = []

    def warning(self, message: str, **options: Any) -> bool:
        self.warnings.append(message)
        result: bool = self.logger.warning(message, **options)
        return result

    def __getattr__(self, name: str) -> Any:
        return getattr(self.logger, name)


class Reader:
    """What the stand-in node's ``create_subscription`` returns: a reader whose events the test
    fires itself."""

    def __init__(self, qos: QoSProfile, events: Any) -> None:
        self.qos_profile = qos
        self.topic_name = "/camera"
        self.events = events


class StandInNode:
    """The part of an rclpy node a ``FollowingSubscription`` uses; ``gate``, when set, holds
    every reader made after the first until it is opened."""

    def __init__(self, *publishers: Any) -> None:
        self.publishers = list(publishers)
        self.readers: list[Reader] = []
        self.destroyed: list[Reader] = []
        self.destroyed_one = threading.Event()
        self.gate: threading.Event | None = None
        self.creating = threading.Event()
        self.warnings: list[str] = []
        self.without_message_lost = False
        """Set: ``create_subscription`` raises as rclpy does on an rmw without the event."""

    def get_publishers_info_by_topic(self, _topic: str) -> list[Any]:
        return list(self.publishers)

    def create_subscription(
        self, _msg_class: type, _topic: str, _callback: Any, qos: QoSProfile, **options: Any
    ) -> Reader:
        if self.readers and self.gate is not None:
            self.creating.set()
            assert self.gate.wait(QUICK * 4)
        if self.without_message_lost and options["event_callbacks"].message_lost is not None:
            raise UnsupportedEventTypeError("message lost event is not supported")
        reader = Reader(qos, options["event_callbacks"])
        self.readers.append(reader)
        return reader

    def destroy_subscription(self, reader: Reader) -> None:
        self.destroyed.append(reader)
        self.destroyed_one.set()

    def get_logger(self) -> Any:
        return SimpleNamespace(info=lambda _text: None, warning=self.warnings.append)


def following(node: StandInNode) -> SensorSubscription:
    return SensorSubscription(
        node,
        msg_class=Image,
        topic="camera",
        callback=lambda _msg: None,
        raw=False,
        callback_group=MutuallyExclusiveCallbackGroup(),
        describe="agent 'camera'",
    )


def switch(node: StandInNode, sub: SensorSubscription) -> Reader:
    """A best-effort publisher joins; the new reader, once the sub switched to it."""
    node.publishers.append(BEST_EFFORT)
    node.readers[0].events.incompatible_qos(RELIABILITY_INCOMPATIBLE)
    assert sub.switched.wait(QUICK)
    new = node.readers[-1]
    assert sub.subscription is new
    return new


def test_the_old_reader_goes_once_the_new_one_hears_what_it_hears_now() -> None:
    """A publisher the old reader heard left during the switch: the old reader kept the count of
    the switch, which the new one never reached, and was kept for good (every message twice)."""
    node = StandInNode(RELIABLE, RELIABLE)
    sub = following(node)
    old = node.readers[0]
    old.events.matched(matched(2))
    new = switch(node, sub)
    new.events.matched(matched(1))
    assert node.destroyed == []  # the new reader has not heard both yet
    old.events.matched(matched(1))  # one of the two left
    assert node.destroyed == [old]
    sub.close()


def test_the_old_reader_goes_when_all_its_publishers_left() -> None:
    node = StandInNode(RELIABLE)
    sub = following(node)
    old = node.readers[0]
    old.events.matched(matched(1))
    switch(node, sub)
    old.events.matched(matched(0))
    assert node.destroyed == [old]
    sub.close()


def test_the_old_reader_goes_after_the_longest_overlap(monkeypatch: pytest.MonkeyPatch) -> None:
    """Whatever the counts say, two readers never deliver every message twice for good."""
    monkeypatch.setattr(following_subscription, "MAX_OVERLAP", 0.05)
    node = StandInNode(RELIABLE, RELIABLE)
    sub = following(node)
    old = node.readers[0]
    old.events.matched(matched(2))
    new = switch(node, sub)
    new.events.matched(matched(1))
    assert node.destroyed_one.wait(QUICK)
    assert node.destroyed == [old]
    sub.close()


def test_the_old_reader_keeps_being_taken_while_the_new_one_is_made() -> None:
    """The new reader was made (and the switch logged: 30-70 ms) in the executor's callback, so
    the old reader was not taken meanwhile and its keep-last queue dropped messages of a
    reliable publisher (5-14 in a row at 500 Hz)."""
    node = StandInNode(RELIABLE)
    sub = following(node)
    old = node.readers[0]
    old.events.matched(matched(1))
    node.gate = threading.Event()
    node.publishers.append(BEST_EFFORT)
    try:
        event = threading.Thread(
            target=old.events.incompatible_qos, args=(RELIABILITY_INCOMPATIBLE,), daemon=True
        )
        event.start()
        assert node.creating.wait(QUICK)
        event.join(QUICK)
        assert not event.is_alive(), "the event's callback waits for the new reader"
        # The executor goes on with the old reader's callbacks, its events included.
        also = threading.Thread(target=old.events.matched, args=(matched(1),), daemon=True)
        also.start()
        also.join(QUICK)
        assert not also.is_alive(), "the old reader's events wait for the new reader"
        assert sub.subscription is old
        assert node.destroyed == []
    finally:
        node.gate.set()
    new = switch(node, sub)
    new.events.matched(matched(2))
    assert node.destroyed == [old]
    sub.close()


def test_close_during_a_switch_leaves_no_reader() -> None:
    node = StandInNode(RELIABLE)
    sub = following(node)
    node.readers[0].events.matched(matched(1))
    node.gate = threading.Event()
    node.publishers.append(BEST_EFFORT)
    node.readers[0].events.incompatible_qos(RELIABILITY_INCOMPATIBLE)
    assert node.creating.wait(QUICK)
    closing = threading.Thread(target=sub.close, daemon=True)
    closing.start()
    node.gate.set()
    closing.join(QUICK)
    assert not closing.is_alive()
    assert sorted(map(id, node.destroyed)) == sorted(map(id, node.readers))
    assert len(node.readers) == 2


def test_losses_are_counted_over_the_switch_and_warned_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """Only incompatible-QoS and matched events were registered: DDS's message_lost events were
    never heard, and a reader losing frames said nothing."""
    from pyconnect.ros import following_subscription

    # Counted where the rmw can take the event without deadlocking (not Fast DDS).
    monkeypatch.setattr(following_subscription, "_losses_deadlock", lambda: False)
    node = StandInNode(RELIABLE)
    sub = following(node)
    old = node.readers[0]
    old.events.matched(matched(1))
    old.events.message_lost(lost(0, 0))  # nothing lost yet: no warning
    assert (sub.lost_count, node.warnings) == (0, [])
    old.events.message_lost(lost(2, 2))
    new = switch(node, sub)
    new.events.message_lost(lost(3, 3))  # the new reader counts from 0 again
    old.events.message_lost(lost(4, 2))  # the retiring one goes on losing meanwhile
    assert sub.lost_count == 7
    assert node.warnings == [
        "agent 'camera': DDS lost 2 message(s) on /camera so far before they reached the "
        "subscription (the agent's lost_count counts on)"
    ]
    sub.close()


def test_an_rmw_without_message_lost_still_subscribes() -> None:
    """rclpy raises for a message_lost event the rmw lacks (it skips the other events): the
    subscription is made without it, counting nothing."""
    node = StandInNode(RELIABLE)
    node.without_message_lost = True
    sub = following(node)
    assert sub.subscription is node.readers[0]
    assert node.readers[0].events.message_lost is None
    assert sub.lost_count == 0
    sub.close()
