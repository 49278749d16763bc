"""The QoS a recorder subscribes with, and what it stores of the publishers, as rosbag2 does.

``node.record()`` (pyconnect.ros.recording) and ``pyconnect bag record`` subscribe to a topic
with ``recording_qos``: reliable unless a publisher is best effort, transient local when every
publisher is (so a latched message sent before the recording starts is recorded too), and a
deep queue. ``offered_qos_yaml`` writes the publishers' profiles as rosbag2 stores a topic's
``offered_qos_profiles`` (what ``bag play`` offers again); ``offered_type_hash`` is their
type's RIHS01 hash as rosbag2 stores its ``type_description_hash`` (what a reader compares
with its installed type).
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call"

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from rclpy.qos import QoSProfile

from pyconnect.ros.qos import matching_qos
from pyconnect.typesys.names import full_type_name

RECORD_DEPTH = 1000
"""Messages a recorder's subscription keeps until the executor takes them. rosbag2 keeps 10,
with callbacks in C++; here a callback waits for the GIL whenever the writer thread (a file
split: several ms), a topic being added or the garbage collector holds it, and at 1 kHz 10
messages last 10 ms. 1000 last a second; DDS allocates them only while they wait."""

_RELIABILITY = {"RELIABLE": 1, "BEST_EFFORT": 2}
_DURABILITY = {"TRANSIENT_LOCAL": 1, "VOLATILE": 2}
_HISTORY = {"KEEP_LAST": 1, "KEEP_ALL": 2}
_LIVELINESS = {"AUTOMATIC": 1, "MANUAL_BY_TOPIC": 3}
_INFINITE = {"sec": 2147483647, "nsec": 4294967295}


def recording_qos(publishers: Sequence[Any]) -> QoSProfile:
    """The QoS a recorder subscribes to a topic of ``publishers`` with."""
    return matching_qos(publishers, depth=RECORD_DEPTH)


def offered_qos_yaml(endpoints: Sequence[Any]) -> str:
    """The publishers' QoS as rosbag2 writes ``offered_qos_profiles`` (a YAML list)."""
    import yaml

    profiles = []
    for endpoint in endpoints:
        qos = endpoint.qos_profile
        profiles.append(
            {
                "history": _HISTORY.get(qos.history.name, 3),  # 3: unknown
                "depth": int(qos.depth),
                "reliability": _RELIABILITY.get(qos.reliability.name, 0),
                "durability": _DURABILITY.get(qos.durability.name, 0),
                "deadline": _duration(qos.deadline),
                "lifespan": _duration(qos.lifespan),
                "liveliness": _LIVELINESS.get(qos.liveliness.name, 0),
                "liveliness_lease_duration": _duration(qos.liveliness_lease_duration),
                "avoid_ros_namespace_conventions": False,
            }
        )
    return yaml.safe_dump(profiles, sort_keys=False) if profiles else ""


def offered_type_hash(endpoints: Sequence[Any], msg_type: str) -> str:
    """The RIHS01 hash the publishers of ``msg_type`` give for it, "" when none gives one or
    they disagree (rosbag2's ``type_description_hash_for_topic``).

    The publishers' hash, not the installed type's: it says what the messages were written
    with, so a reader whose installed type differs can tell; the installed one always matches.
    """
    msg_type = full_type_name(msg_type)
    found = set()
    for endpoint in endpoints:
        if endpoint.topic_type != msg_type:
            continue  # a publisher of another type: the recorder's subscription never hears it
        text = str(endpoint.topic_type_hash)
        if text.startswith("RIHS"):  # rclpy says "INVALID" for an RMW that sends no hash
            found.add(text)
    # Two hashes: one of them is not what the messages were written with, and which is unknown.
    return found.pop() if len(found) == 1 else ""


def _duration(value: Any) -> dict[str, int]:
    ns = int(value.nanoseconds)
    if ns <= 0 or ns >= _INFINITE["sec"] * 1_000_000_000:
        return dict(_INFINITE)  # rclpy's Infinite, as rosbag2 writes it
    sec, nsec = divmod(ns, 1_000_000_000)
    return {"sec": sec, "nsec": nsec}
