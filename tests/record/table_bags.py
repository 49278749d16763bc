"""Hand-made bags for the table and align tests: rclpy messages serialised into an MCAP bag."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

from rclpy.serialization import serialize_message

from pyconnect.record.mcap_recorder import McapRecorder


def stamp_of(ns: int) -> tuple[int, int]:
    """``ns`` as (sec, nanosec)."""
    return divmod(ns, 1_000_000_000)


def write_bag(path: Path, messages: Iterable[tuple[str, int, Any]]) -> Path:
    """A bag directory holding ``(topic, log_time_ns, rclpy message)`` in order of writing."""
    with McapRecorder(path) as recorder:
        for topic, log_time_ns, message in messages:
            module = type(message).__module__.split(".")[0]
            recorder.add_topic(topic, f"{module}/msg/{type(message).__name__}")
            recorder.write(topic, serialize_message(message), log_time_ns=log_time_ns)
    return path
