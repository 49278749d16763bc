"""The one rule both action servers (CustomNode's and a Peer's) use to call a handler."""

from __future__ import annotations

import functools
from typing import Any

from pyconnect.ros.handler_shape import wants_feedback_publisher


def goal_only(goal: Any) -> Any:
    return goal


def with_feedback(goal: Any, publish_feedback: Any) -> Any:
    return goal


def feedback_by_name(goal: Any, publish_feedback: Any = None) -> Any:
    return goal


def optional_other(goal: Any, scale: float = 1.0) -> Any:
    return goal


def any_positional(*args: Any) -> Any:
    return args


class Server:
    def run(self, goal: Any, publish_feedback: Any) -> Any:
        return goal


def test_the_second_positional_parameter_asks_for_the_feedback_publisher() -> None:
    assert [
        wants_feedback_publisher(handler)
        for handler in (
            goal_only,
            with_feedback,
            feedback_by_name,
            optional_other,
            any_positional,
            Server().run,
            functools.partial(with_feedback, publish_feedback=None),
            lambda goal: goal,
            max,  # no readable signature: the goal alone
        )
    ] == [False, True, True, False, True, True, False, False, False]
