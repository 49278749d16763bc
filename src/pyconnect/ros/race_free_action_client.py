"""An rclpy ``ActionClient`` whose goal, cancel and result requests cannot lose their response.

rclpy 7.1 (Jazzy) sends a request and only then records its sequence number; a response taken
by the executor thread in between is dropped with "Ignoring unexpected goal response" and the
future never completes (ros2/rclpy#1123, fixed upstream by ros2/rclpy#1308 after the Jazzy
wheel we install). This subclass holds a lock over "send and record", and handling a response
first passes that lock: the request a response answers was sent before the response existed,
so once the lock is passed it is recorded. No lock is held while callbacks run.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,no-any-return"

from __future__ import annotations

import threading
from typing import Any

from rclpy.action.client import ActionClient
from rclpy.task import Future


class RaceFreeActionClient(ActionClient):
    """``rclpy.action.ActionClient`` with the request/response race closed."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self._recording = threading.Lock()
        super().__init__(*args, **kwargs)

    def send_goal_async(
        self, goal: Any, feedback_callback: Any = None, goal_uuid: Any = None
    ) -> Future:
        with self._recording:
            return super().send_goal_async(goal, feedback_callback, goal_uuid)

    def _cancel_goal_async(self, goal_handle: Any) -> Future:
        with self._recording:
            return super()._cancel_goal_async(goal_handle)

    def _get_result_async(self, goal_handle: Any) -> Future:
        with self._recording:
            return super()._get_result_async(goal_handle)

    async def execute(self, taken_data: Any) -> None:
        with self._recording:
            pass  # a send still recording its sequence number finishes first
        await super().execute(taken_data)
