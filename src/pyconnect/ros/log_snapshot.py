"""A logged value as it is at ``log_msg()``: copies of what the caller may change afterwards.

An agent's log files are written on a writer thread, while the callback that logged a value
goes on: a subscriber hands the same decoded image to ``response_func`` (which may draw on
it), a publisher's caller refills its frame buffer for the next ``send()``. Immutable values
pass as they are; arrays are copied with one memcpy; containers and messages are deep-copied.
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np

_IMMUTABLE = (str, bytes, int, float, bool, type(None))


def snapshot(value: Any) -> Any:
    """``value``, or a copy of it that later changes to ``value`` do not reach."""
    if isinstance(value, _IMMUTABLE):
        return value
    if isinstance(value, np.ndarray):  # read-only ones too: their base may be written
        return value.copy()
    try:
        return copy.deepcopy(value)
    except Exception:  # a value deepcopy cannot take: logged as it is (as before)
        return value
