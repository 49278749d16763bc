"""The QoS of the live commands' endpoints: what the ``--qos-*`` options ask for, and for ``topic
echo`` without them a subscription that keeps matching its publishers.

ros2cli's rules: ``--qos-profile`` names a preset, and ``--qos-depth``, ``--qos-history``,
``--qos-reliability`` and ``--qos-durability`` each override one policy of it (of the verb's
own default when no preset is named); a transient-local profile of depth 0 gets depth 1.
``topic echo`` given no preset, reliability or durability matches its publishers, as ``ros2
topic echo`` does, and goes on matching them: a best-effort or volatile publisher discovered
after it subscribed relaxes the subscription (pyconnect.ros.following_subscription) instead of
going unheard.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import argparse
import copy
from collections.abc import Callable
from typing import Any

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from pyconnect.commands.graph import preset_qos
from pyconnect.ros.following_subscription import FollowingSubscription

__all__ = ["ECHO_DEPTH", "EchoSubscription", "follows_publishers", "requested_qos"]

ECHO_DEPTH = 10
"""The queue of echo's subscription when ``--qos-depth`` does not say (ros2's default depth)."""


def follows_publishers(args: argparse.Namespace) -> bool:
    """True when ``topic echo``'s QoS is left to its publishers: neither a preset, nor a
    reliability or durability given (depth and history do not decide whom it hears)."""
    return args.qos_profile is None and args.qos_reliability is None and args.qos_durability is None


def requested_qos(args: argparse.Namespace, default: QoSProfile) -> QoSProfile:
    """The ``--qos-profile`` preset (else ``default``) with the policies the other ``--qos-*``
    options name put in place of its own."""
    # A copy: rclpy's presets are shared objects, and main() may run again in this process.
    profile: QoSProfile = copy.copy(preset_qos(args.qos_profile) if args.qos_profile else default)
    if args.qos_history:
        profile.history = HistoryPolicy.get_from_short_key(args.qos_history)
    if args.qos_reliability:
        profile.reliability = ReliabilityPolicy.get_from_short_key(args.qos_reliability)
    if args.qos_durability:
        profile.durability = DurabilityPolicy.get_from_short_key(args.qos_durability)
    if args.qos_depth is not None:
        profile.depth = args.qos_depth
    elif profile.durability == DurabilityPolicy.TRANSIENT_LOCAL and profile.depth == 0:
        profile.depth = 1  # as ros2cli: a latched message needs a place to be kept
    return profile


class EchoSubscription(FollowingSubscription):
    """``topic echo``'s subscription when no QoS is given: its reliability and durability follow
    the publishers, late ones included; its depth and history are the options'."""

    def __init__(
        self,
        ros_node: Any,
        *,
        msg_class: type,
        topic: str,
        callback: Callable[[Any], None],
        raw: bool,
        args: argparse.Namespace,
    ) -> None:
        self._depth = ECHO_DEPTH if args.qos_depth is None else args.qos_depth
        self._history = (
            HistoryPolicy.KEEP_LAST
            if not args.qos_history
            else HistoryPolicy.get_from_short_key(args.qos_history)
        )
        super().__init__(
            ros_node,
            msg_class=msg_class,
            topic=topic,
            callback=callback,
            raw=raw,
            callback_group=None,
        )

    def profile(self, reliability: ReliabilityPolicy, durability: DurabilityPolicy) -> QoSProfile:
        return QoSProfile(
            depth=self._depth, history=self._history, reliability=reliability, durability=durability
        )

    def switch_text(self, old: QoSProfile, new: QoSProfile) -> str:
        return (
            f"[{self.topic}]: a publisher it could not hear appeared: subscribed again "
            f"{_policies(new)} (was {_policies(old)})"
        )


def _policies(profile: QoSProfile) -> str:
    return f"{profile.reliability.name.lower()}, {profile.durability.name.lower()}"
