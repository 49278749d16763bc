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


def plain(value: Any) -> Any:
    """A comparable form of a decoded value: dicts, lists, ints, floats (NaN equal to NaN), str.

    rosbags gives dataclasses and numpy arrays, our dicts give bytes for ``uint8[]``/``byte[]``
    fields and lists or arrays for other sequences: all become lists of Python scalars.
    """
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
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
