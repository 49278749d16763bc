"""What one node's zenoh -> ROS bridge agents just published on ROS, so that its ROS -> zenoh
agent of the same topic skips each once when it comes back (pyconnect.ros.zenoh_bridge).

rclpy Jazzy's message info names no publisher, so the copies are recognised by their bytes: a
digest per message, kept ``ECHO_SECONDS`` at most. A message is recorded only when a ROS ->
zenoh agent of the topic on the node can hear the publisher's QoS (a reliable reader never
hears a best-effort publisher: the copy would never come back, and the record would take the
place of another publisher's message of the same bytes). Another ROS publisher's message of the
very same bytes within that time is forwarded as long as it is not the only copy to arrive.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import collections
import threading
import time
from collections.abc import Callable

import xxhash
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from pyconnect.transport.peer_options import KEEP_ALL_DEPTH

ECHO_SECONDS = 1.0
"""How long a message a zenoh -> ROS agent published waits to come back to the same node's
ROS -> zenoh agent of the topic (local delivery takes milliseconds; a lost copy expires)."""
ECHO_LIMIT = KEEP_ALL_DEPTH
"""At most this many messages per topic wait to come back (the oldest are forgotten)."""

Hears = Callable[[QoSProfile], bool]
"""Whether a reader hears a publisher offering this QoS."""


def qos_compatible(publisher: QoSProfile, reader: QoSProfile) -> bool:
    """Whether a reader with ``reader``'s QoS hears a publisher offering ``publisher``'s (the
    two policies where DDS refuses a match: reliability and durability)."""
    if (
        reader.reliability == ReliabilityPolicy.RELIABLE
        and publisher.reliability == ReliabilityPolicy.BEST_EFFORT
    ):
        return False
    return not (
        reader.durability == DurabilityPolicy.TRANSIENT_LOCAL
        and publisher.durability == DurabilityPolicy.VOLATILE
    )


class RecentlyPublished:
    """Per topic, the digests of what this node's zenoh -> ROS agents published lately."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._readers: dict[str, list[Hears]] = {}
        """Topics with a ROS -> zenoh agent on this node, and what each of those hears."""
        self._sent: dict[str, collections.deque[tuple[float, bytes]]] = {}

    def watch(self, topic: str, hears: Hears) -> None:
        with self._lock:
            self._readers.setdefault(topic, []).append(hears)

    def unwatch(self, topic: str, hears: Hears) -> None:
        with self._lock:
            readers = self._readers.get(topic, [])
            if hears in readers:
                readers.remove(hears)
            if not readers:
                self._readers.pop(topic, None)
                self._sent.pop(topic, None)

    def published(self, topic: str, payload: bytes, qos: QoSProfile) -> None:
        """Record ``payload`` before it goes on ROS with ``qos`` (the copy may come back at
        once), when a reader of the topic on this node hears that QoS."""
        if topic not in self._readers:  # read without the lock: a dict lookup is atomic
            return
        digest = _digest(payload)
        with self._lock:
            readers = self._readers.get(topic)
            if not readers or not any(hears(qos) for hears in readers):
                return
            sent = self._sent.setdefault(topic, collections.deque(maxlen=ECHO_LIMIT))
            sent.append((time.monotonic() + ECHO_SECONDS, digest))

    def came_back(self, topic: str, payload: bytes) -> bool:
        """Whether ``payload`` is one this node published on ``topic`` lately (forgotten now)."""
        if not self._sent.get(topic):
            return False
        digest = _digest(payload)
        now = time.monotonic()
        with self._lock:
            sent = self._sent.get(topic)
            if not sent:
                return False
            while sent and sent[0][0] < now:
                sent.popleft()
            for index, (_expiry, recorded) in enumerate(sent):
                if recorded == digest:
                    del sent[index]
                    return True
            return False


def _digest(payload: bytes) -> bytes:
    # 128 bits and the length: two different messages never collide in practice.
    return xxhash.xxh3_128_digest(payload) + len(payload).to_bytes(8, "little")
