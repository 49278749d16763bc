"""Where the shared sample bags are, what EXPECTED.json says about them, and value comparison."""

from __future__ import annotations

import dataclasses
import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np

BAGS = (Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "bags").resolve()


def expected_bags() -> dict[str, Any]:
    """EXPECTED.json's ``bags``: bag key (path relative to BAGS) -> topics and decoder results."""
    if not (BAGS / "EXPECTED.json").is_file():
        return {}
    bags: dict[str, Any] = json.loads((BAGS / "EXPECTED.json").read_text())["bags"]
    return bags


_OK = re.compile(r"^(\d+) ok/")
_DECODERS = (
    "rosbags",
    "mcap_ros2",
    "rclpy(mcap raw)",
    "rclpy(sqlite raw)",
    "rclpy(via rosbags raw)",
)


def reference_decoded(topic: dict[str, Any]) -> bool:
    """Whether at least one reference decoder decoded at least one message of the topic."""
    for decoder in _DECODERS:
        results = topic.get(decoder)
        if results is None:
            continue
        for result in results.values() if isinstance(results, dict) else [results]:
            match = _OK.match(result)
            if match and int(match.group(1)) > 0:
                return True
    return False


_EMPTY_MEMBER = "structure_needs_at_least_one_member"  # rosbags' stand-in field of empty types


def plain(value: Any) -> Any:
    """A comparable form of a decoded value: dicts, lists, ints, floats (NaN equal to NaN), str.

    rosbags gives dataclasses and numpy arrays, our dicts give bytes for ``uint8[]``/``byte[]``
    fields and lists or arrays for other sequences: all become lists of Python scalars.
    """
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {
            f.name: plain(getattr(value, f.name))
            for f in dataclasses.fields(value)
            # rosbags lists constants (UPPER_CASE; ROS 2 field names are lower case) as fields
            if not f.name.startswith("__") and f.name != _EMPTY_MEMBER and not f.name.isupper()
        }
    if isinstance(value, dict):
        return {key: plain(item) for key, item in value.items()}
    if isinstance(value, np.ndarray):
        return [plain(item) for item in value.tolist()]
    if isinstance(value, bytes | bytearray | memoryview):
        return list(bytes(value))
    if isinstance(value, list | tuple):
        return [plain(item) for item in value]
    if isinstance(value, np.generic):
        return plain(value.item())
    if isinstance(value, float) and math.isnan(value):
        return "NaN"
    if isinstance(value, bool):
        return int(value)
    return value


def same_as_rosbags(ours: Any, theirs: Any) -> bool:
    """``plain`` values equal, except that rosbags reads ROS 2 ``byte`` (an unsigned octet, as
    rclpy reads it) as int8: there, ours == theirs + 256."""
    if isinstance(ours, dict) and isinstance(theirs, dict):
        return ours.keys() == theirs.keys() and all(
            same_as_rosbags(ours[key], theirs[key]) for key in ours
        )
    if isinstance(ours, list) and isinstance(theirs, list):
        return len(ours) == len(theirs) and all(map(same_as_rosbags, ours, theirs))
    if type(ours) is int and type(theirs) is int and -128 <= theirs < 0:
        return ours in (theirs, theirs + 256)
    return bool(ours == theirs)
