"""An rclpy ``ActionClient`` whose goal, cancel and result requests cannot lose their response.

rclpy 7.1 (Jazzy) sends a request and only then records its sequence number; a response taken
by the executor thread in between is dropped with "Ignoring unexpected goal response" and the
future never completes (ros2/rclpy#1123, fixed upstream by ros2/rclpy#1308 after the Jazzy
wheel we install). This subclass holds a lock over "send and record", and handling a response
first passes that lock: the request a response answers was sent before the response existed,
so once the lock is passed it is recorded. No lock is held while callbacks run.

It also takes every feedback message waiting, not one per wake-up, and hands them on before
the result: rclpy drops a goal's feedback callback once its result is handled, so feedback
published in a burst just before the result was lost (all but the first few of a quick goal).
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,no-any-return"

from __future__ import annotations

import threading
from typing import Any

from rclpy.action.client import ActionClient
from rclpy.executors import await_or_execute
from rclpy.task import Future


class RaceFreeActionClient(ActionClient):
    """``rclpy.action.ActionClient`` with the request/response race closed."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self._recording = threading.Lock()
        super().__init__(*args, **kwargs)
        self._feedback_type = self._action_type.Impl.FeedbackMessage

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

    def take_data(self) -> Any:
        data = super().take_data()
        first = data.pop("feedback", None)
        if first is not None:
            waiting = [first]
            while (more := self._client_handle.take_feedback(self._feedback_type)) is not None:
                waiting.append(more)
            data["all_feedback"] = waiting
        return data

    async def execute(self, taken_data: Any) -> None:
        with self._recording:
            pass  # a send still recording its sequence number finishes first
        for feedback in taken_data.pop("all_feedback", ()):  # before the result drops the callback
            callback = self._feedback_callbacks.get(bytes(feedback.goal_id.uuid))
            if callback is not None:
                await await_or_execute(callback, feedback)
        await super().execute(taken_data)
