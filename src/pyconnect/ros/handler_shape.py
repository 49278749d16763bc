"""How a user's action handler asks to be called: with a feedback publisher or without.

Shared by ``CustomNode``'s action servers and a ``Peer``'s (pyconnect.transport), so the rule is
one; no rclpy here, as a peer runs without ROS.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any


def wants_feedback_publisher(function: Callable[..., Any]) -> bool:
    """True when ``response_func`` takes a second positional argument (``publish_feedback``).

    Counted: parameters without a default, a parameter named ``publish_feedback`` (with or
    without a default), and ``*args`` (as two). A callable whose signature cannot be read is
    called with the goal alone.
    """
    try:
        parameters = inspect.signature(function).parameters.values()
    except (TypeError, ValueError):
        return False
    count = 0
    for parameter in parameters:
        if parameter.kind is inspect.Parameter.VAR_POSITIONAL:
            return True
        if parameter.kind in (
            inspect.Parameter.POSITIONAL_ONLY,
            inspect.Parameter.POSITIONAL_OR_KEYWORD,
        ) and (
            parameter.default is inspect.Parameter.empty or parameter.name == "publish_feedback"
        ):
            count += 1
    return count >= 2
