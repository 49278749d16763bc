"""What a peer's action agents share: rcl_action's names, goal states, nested CDR, error texts.

rmw_zenoh knows nothing of actions: rcl_action (``names.c``, ``action_server.c``) builds each of
three services and two topics under ``<action>/_action/``, and rmw_zenoh maps them like any
other (rmw_zenoh_keys). Their types: ``send_goal`` is ``<pkg>/action/<Name>_SendGoal``,
``get_result`` is ``<pkg>/action/<Name>_GetResult``, ``cancel_goal`` is
``action_msgs/srv/CancelGoal``, ``feedback`` carries ``<pkg>/action/<Name>_FeedbackMessage``
and ``status`` ``action_msgs/msg/GoalStatusArray`` (rcl_action's status QoS: reliable,
transient-local, depth 1; the others: reliable, volatile, depth 10).

A pyconnect server also publishes why it aborted a goal on ``<action>/_action/abort_reason``
(``diagnostic_msgs/msg/KeyValue``: goal id in hex, text), as ``CustomNode``'s does
(pyconnect.ros.abort_reasons), so either kind of pyconnect client shows the reason.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

from pyconnect.codecs.wire import WireCodec

SEND_GOAL, CANCEL_GOAL, GET_RESULT = "send_goal", "cancel_goal", "get_result"
FEEDBACK, STATUS, ABORT_REASON = "feedback", "status", "abort_reason"
ABORT_REASON_TYPE = "diagnostic_msgs/msg/KeyValue"

# action_msgs/msg/GoalStatus
UNKNOWN, ACCEPTED, EXECUTING, CANCELING, SUCCEEDED, CANCELED, ABORTED = range(7)
ACTIVE = (ACCEPTED, EXECUTING, CANCELING)
# action_msgs/srv/CancelGoal_Response return codes
CANCEL_NONE, CANCEL_REJECTED, CANCEL_UNKNOWN_GOAL, CANCEL_TERMINATED = range(4)

_TEXT_FIELDS = ("message", "error", "error_message", "error_msg", "error_string", "reason")


def part_name(action_name: str, part: str) -> str:
    """rcl_action's name of one of an action's services or topics."""
    return f"{action_name.rstrip('/')}/_action/{part}"


def stamp_now() -> dict[str, int]:
    nanoseconds = time.time_ns()
    return {"sec": nanoseconds // 1_000_000_000, "nanosec": nanoseconds % 1_000_000_000}


def stamp_ns(stamp: Mapping[str, Any]) -> int:
    return int(stamp["sec"]) * 1_000_000_000 + int(stamp["nanosec"])


def nested(codec: WireCodec, payload: bytes) -> dict[str, Any]:
    """A message's lossless dict, to put inside an enclosing message (its CDR cannot be
    spliced: alignment counts from the enclosing message's start)."""
    return codec.to_dict(payload)


def error_result(codec: WireCodec, text: str) -> dict[str, Any]:
    """A default result with ``success=False`` and ``text`` in its first text field, if any."""
    fields = codec.to_dict(codec.from_dict({}))
    answer: dict[str, Any] = {}
    if isinstance(fields.get("success"), bool):
        answer["success"] = False
    for name in _TEXT_FIELDS:
        if isinstance(fields.get(name), str):
            answer[name] = text
            break
    return answer


def error_text(result: Mapping[str, Any]) -> str:
    """The error text a result dict carries in a text field, or an empty string."""
    for name in _TEXT_FIELDS:
        value = result.get(name)
        if isinstance(value, str):
            return value
    return ""
