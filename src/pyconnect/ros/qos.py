"""QoS profiles by name, and the defaults agents pick for sensor streams.

Services and actions use ``REQUESTS`` (keep all), so no request or response is dropped.

``qos=`` on an agent takes a ``QoSProfile``, ``'default'`` (reliable, volatile, keep last 10),
``'sensor_data'`` (best effort, volatile, keep last 5) or ``'latched'`` (reliable,
transient local, keep last 1: late subscribers get the last message).

Sensor streams (``SENSOR_TYPES``: images, point clouds, scans, IMU, ...) default to profiles
that connect to the common camera and lidar drivers whatever they chose, without losing large
frames. A *publisher* is reliable with a short queue, because a reliable writer matches both
kinds of reader (rviz and ``ros2 topic echo`` subscribe reliably by default). A *subscriber*
follows the publishers it sees, as ROS 2's "best available" does: reliable when every one of
them is reliable (or there is none yet), best effort when one is best effort
(``matching_reliability``), transient local when all are (``matching_qos``); and it relaxes
when a publisher it cannot hear appears later (pyconnect.ros.following_subscription), because
a reliable reader never matches a best-effort writer (the usual "no images arrive" surprise).
Why not best effort always: on stock Fast DDS a best-effort reader loses about half of the
640x480 frames and nearly every 1080p frame (UDP fragments), a reliable one none
(bench/sensor_qos.py). An explicit ``qos=`` is never adapted.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_sensor_data,
)

from pyconnect.errors import PyconnectError

SENSOR_TYPES = frozenset(
    {
        "sensor_msgs/msg/Image",
        "sensor_msgs/msg/CompressedImage",
        "sensor_msgs/msg/PointCloud2",
        "sensor_msgs/msg/PointCloud",
        "sensor_msgs/msg/LaserScan",
        "sensor_msgs/msg/MultiEchoLaserScan",
        "sensor_msgs/msg/Imu",
        "sensor_msgs/msg/CameraInfo",
        "sensor_msgs/msg/Range",
        "sensor_msgs/msg/MagneticField",
        "sensor_msgs/msg/NavSatFix",
    }
)

DEFAULT = QoSProfile(
    depth=10,
    history=HistoryPolicy.KEEP_LAST,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
SENSOR_DATA: QoSProfile = qos_profile_sensor_data
LATCHED = QoSProfile(
    depth=1,
    history=HistoryPolicy.KEEP_LAST,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
SENSOR_PUBLISHER = QoSProfile(
    depth=5,
    history=HistoryPolicy.KEEP_LAST,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)


def matching_reliability(publishers: Iterable[Any]) -> ReliabilityPolicy:
    """The reliability a reader needs to hear all ``publishers`` (rclpy ``TopicEndpointInfo``).

    Reliable when every one of them is reliable (or there is none), else best effort (a reliable
    reader never matches a best-effort writer), so no frame is dropped when none has to be:
    ROS 2's "best available" rule (rmw_dds_common's
    ``qos_profile_get_best_available_for_subscription``), also what ``ros2 topic echo`` picks.
    pyconnect applies it itself rather than passing ``ReliabilityPolicy.BEST_AVAILABLE``
    (which the Jazzy wheels accept): rmw decides that once, at creation, usually before
    discovery has found anyone, and the agent must know the outcome to switch later.
    """
    reliable = all(p.qos_profile.reliability == ReliabilityPolicy.RELIABLE for p in publishers)
    return ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT


def matching_qos(publishers: Sequence[Any], *, depth: int) -> QoSProfile:
    """A reader's QoS that hears every one of ``publishers`` (rclpy ``TopicEndpointInfo``),
    latched messages included, as ``ros2 topic echo`` and ``ros2 bag record`` pick it."""
    latched = bool(publishers) and all(
        p.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in publishers
    )
    return QoSProfile(
        depth=depth,
        reliability=matching_reliability(publishers),
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
    )


def follows_publishers(qos: object, *, msg_type: str) -> bool:
    """True when a subscriber's QoS is chosen from its publishers: a sensor type, no ``qos=``."""
    return qos is None and msg_type in SENSOR_TYPES


REQUESTS = QoSProfile(
    depth=1,
    history=HistoryPolicy.KEEP_ALL,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""Services and actions' goal/cancel/result services of every agent (both sides).

rclpy's default (keep last 10) loses requests silently in a burst: Fast DDS publishes
asynchronously, so a client's 11th request can replace its 1st in the writer's queue before
that was sent, and a busy server's reader keeps only the newest 10 it has not taken yet
(20 result requests sent at once lost 1-10 of the first ones in one run in two). Keep-all
queues every request and response until it is delivered and taken; history is not part of
QoS matching, so plain rclpy peers with the default still connect.
"""

MAX_DEPTH = 2**31 - 1
"""The largest ``qos=<int>`` depth an agent takes."""

NAMED_PROFILES: dict[str, QoSProfile] = {
    "default": DEFAULT,
    "sensor_data": SENSOR_DATA,
    "latched": LATCHED,
}


def resolve_qos(
    qos: QoSProfile | str | int | None, *, msg_type: str, publisher: bool
) -> QoSProfile:
    """The profile an agent uses: an explicit one, a named one, or the default for its type.

    An int is a queue depth (1 to ``MAX_DEPTH``) with the default policies, as rclpy accepts.
    A sensor subscriber that cannot follow its publishers (``follows_publishers``) gets
    ``SENSOR_DATA``, which hears every publisher.
    """
    if isinstance(qos, QoSProfile):
        return qos
    if isinstance(qos, bool):
        raise PyconnectError(f"qos: expected a QoSProfile, a name or a depth, got {qos!r}")
    if isinstance(qos, int):
        # rmw takes a depth of 1 to 2**31-1: rclpy turned 0 into SYSTEM_DEFAULT with a warning,
        # -1 into an RCLError and more into a pybind TypeError, none naming the agent.
        if not 1 <= qos <= MAX_DEPTH:
            bound = ">= 1" if qos < 1 else f"<= {MAX_DEPTH}"
            raise PyconnectError(f"qos: depth must be {bound}, got {qos!r}")
        return QoSProfile(depth=qos)
    if isinstance(qos, str):
        profile = NAMED_PROFILES.get(qos)
        if profile is None:
            raise PyconnectError(
                f"qos: unknown profile {qos!r}; expected a QoSProfile or one of "
                f"{', '.join(repr(name) for name in NAMED_PROFILES)}"
            )
        return profile
    if qos is None:
        if msg_type in SENSOR_TYPES:
            return SENSOR_PUBLISHER if publisher else SENSOR_DATA
        return DEFAULT
    raise PyconnectError(f"qos: expected a QoSProfile, a name or a depth, got {type(qos).__name__}")
