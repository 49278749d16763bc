"""Make wire-decoded dicts comparable with ``pyconnect.codecs.to_dict`` of rclpy messages.

Wire dicts carry numeric arrays as numpy views of the buffer and ``uint8``/``byte``/``char``
arrays as uint8 views (documented in ``pyconnect.codecs.wire``); the rclpy dicts carry lists
and ``bytes``.
"""

from __future__ import annotations

from typing import Any

import numpy as np


def plain(value: Any) -> Any:
    """``value`` with numpy arrays turned into ``bytes`` (uint8) or lists (numbers)."""
    if isinstance(value, np.ndarray):
        return value.tobytes() if value.dtype == np.uint8 else value.tolist()
    if isinstance(value, dict):
        return {key: plain(item) for key, item in value.items()}
    if isinstance(value, list):
        return [plain(item) for item in value]
    return value
