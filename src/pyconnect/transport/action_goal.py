"""One goal of a peer's action server: its state, its ``publish_feedback``, and driving a
generator handler between cancels (pyconnect.transport.action_server uses them)."""

from __future__ import annotations

import inspect
import threading
from collections.abc import Callable
from typing import Any

from pyconnect.errors import PyconnectError
from pyconnect.transport import action_wire as aw
from pyconnect.transport.async_handlers import run_coroutine
from pyconnect.transport.endpoints import Request


class ServerGoal:
    """One accepted goal: its state, its result once there, and who waits for it."""

    def __init__(self, goal_id: bytes, stamp: dict[str, int]) -> None:
        self.goal_id = goal_id
        self.stamp = stamp
        self.status = aw.ACCEPTED
        self.cancel_requested = threading.Event()
        self.ended = False  # claimed by whoever gives the goal its final state (_end)
        self.result_asked = False  # a get_result request for it has arrived
        self.response: bytes | None = None  # the GetResult response, once finished
        self.finished_at = 0.0
        self.waiting: list[Request] = []


class FeedbackPublisher:
    """``publish_feedback(value)``: feedback of one goal, callable from any thread."""

    def __init__(self, publish: Callable[[ServerGoal, Any], None], goal: ServerGoal) -> None:
        self._publish = publish
        self._goal = goal
        self._lock = threading.Lock()
        self._open = True
        self.published = 0
        """How many feedback messages were published."""

    def __call__(self, value: Any) -> None:
        """Encode ``value`` and publish it as this goal's feedback."""
        with self._lock:
            if not self._open:
                raise PyconnectError("publish_feedback: the goal has already finished")
            self._publish(self._goal, value)
            self.published += 1

    @property
    def cancel_requested(self) -> bool:
        """True once a client asked to cancel this goal (the task may stop early)."""
        return self._goal.cancel_requested.is_set()

    def close(self) -> None:
        with self._lock:
            self._open = False


def drive_generator(
    generator: Any, goal: ServerGoal, publish: FeedbackPublisher, shutting_down: threading.Event
) -> tuple[bool, Any]:
    """Run a generator handler: (True, result) at its end, (False, None) when canceled or
    stopped by the shutdown.

    An async generator has no return value: its result is its last yield. It runs on the goal
    thread's loop (the server's ``_execute`` scopes it), which closes it if it is left unfinished.
    """

    def stopped() -> bool:
        return goal.cancel_requested.is_set() or shutting_down.is_set()

    if inspect.isasyncgen(generator):
        last: Any = None
        while not stopped():
            try:
                last = run_coroutine(generator.__anext__())
            except StopAsyncIteration:
                return True, last
            if last is not None:
                publish(last)
        run_coroutine(generator.aclose())
        return False, None
    while not stopped():
        try:
            feedback = next(generator)
        except StopIteration as stop:
            return True, stop.value
        if feedback is not None:
            publish(feedback)
    generator.close()
    return False, None
