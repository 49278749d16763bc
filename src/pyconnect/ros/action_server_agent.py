"""``action_server`` agents: ``response_func(goal) -> result``, with feedback two ways.

Feedback, either style:
- a *generator* ``response_func`` publishes each yielded value as feedback and its ``return``
  value is the result. A cancel request is honoured between two yields: the generator is
  closed (its ``finally`` blocks run) and the goal ends canceled. An ``async def`` generator
  works the same on the node's coroutine loop.
- a ``response_func(goal, publish_feedback)`` taking a second positional parameter gets a
  ``FeedbackPublisher``: ``publish_feedback(value)`` may be called from any thread (a worker
  thread, a library's progress callback) while the goal runs; its ``cancel_requested`` tells
  the task that a cancel was asked. A generator may take it too: it stays open until the
  generator has ended.
A plain (or ``async def``) function cannot be stopped; if a cancel arrived meanwhile, the goal
ends canceled when it returns.

A handler that raises aborts the goal *with the error text*: rclpy's own server logs the
exception and sends a default result (rclpy#1020), so this agent catches it, aborts, and puts
``"<Exception>: <text>"`` in the result's first string field named ``message``, ``error``,
``error_message``... (pyconnect.ros.error_fields). Result types without such a field (e.g.
``test_msgs/action/Fibonacci``) cannot carry text, so the reason is also published beside the
action's topics (pyconnect.ros.abort_reasons), where pyconnect clients read it.

At shutdown (``close``, after the executor has stopped and waited for running goals) a goal
that finished gets its result sent; one still running is aborted with ``"server is shutting
down"`` (in the result's text field and on the abort-reason topic), so its client hears at once
instead of waiting its whole timeout. Its handler thread is not stopped (Python cannot), and
what it returns later is dropped.

Finished goals leave the server's goal list after ``result_timeout`` seconds (default 0.05 s
instead of rclpy's 900 s): every status message lists every goal kept and every client
converts that list to Python objects several times per goal, so latency grows with the number
kept (docs/ros-facts.md: 1.5 -> 13 ms over 500 goals). Their results stay available
``result_cache_seconds`` (60 s) for late ``get_result`` requests
(pyconnect.ros.retaining_action_server).
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import functools
import inspect
import threading
from collections.abc import Callable
from typing import Any

from rclpy.action import CancelResponse, GoalResponse
from rclpy.callback_groups import CallbackGroup, ReentrantCallbackGroup

from pyconnect.errors import PyconnectError
from pyconnect.ros.abort_reasons import AbortReasonPublisher
from pyconnect.ros.agent_host import AgentHost
from pyconnect.ros.conversion import DecodeFunc, EncodeFunc
from pyconnect.ros.error_fields import error_message
from pyconnect.ros.handler_shape import wants_feedback_publisher
from pyconnect.ros.interfaces import interface_class
from pyconnect.ros.node_agent import CancelledByShutdown, NodeAgent, ResponseFunc
from pyconnect.ros.qos import REQUESTS
from pyconnect.ros.retaining_action_server import RetainingActionServer
from pyconnect.ros.service_agents import SHUTTING_DOWN

DEFAULT_RESULT_TIMEOUT = 0.05
"""Seconds a finished goal stays in the server's goal list (and every status message)."""

DEFAULT_RESULT_CACHE_SECONDS = 60.0
"""Seconds a late ``get_result`` request is still answered (retaining_action_server)."""


class ActionServerAgent(NodeAgent):
    """Executes goals sent to the action ``conn_name`` with ``response_func``.

    A ``response_func`` whose result is None (no ``return``) succeeds with the default result
    (every field at its default); where the result type has fields, the first such goal logs
    a warning.
    """

    conn_type = "action_server"

    def __init__(
        self,
        node: AgentHost,
        *,
        conn_name: str,
        agent_name: str | None = None,
        data_interface: object,
        encode_func: EncodeFunc | None = None,
        decode_func: DecodeFunc | None = None,
        response_func: ResponseFunc | None = None,
        do_log_msg: bool = False,
        result_timeout: float = DEFAULT_RESULT_TIMEOUT,
        result_cache_seconds: float = DEFAULT_RESULT_CACHE_SECONDS,
        callback_group: CallbackGroup | None = None,
    ) -> None:
        action_class = interface_class(data_interface, kind="action")
        super().__init__(
            node,
            conn_name=conn_name,
            agent_name=agent_name,
            data_interface=action_class,
            response_func=response_func,
            do_log_msg=do_log_msg,
            # Reentrant: cancel and new goals are handled while a goal executes.
            callback_group=callback_group or ReentrantCallbackGroup(),
        )
        if response_func is None:
            raise self.error("an 'action_server' agent needs a response_func")
        self._handler: ResponseFunc = response_func
        self._wants_feedback_publisher = wants_feedback_publisher(response_func)
        self._result_class = action_class.Result
        self.goal_conversion = self.make_conversion(
            action_class.Goal, decode_func=decode_func, eager=decode_func is None
        )
        self.result_conversion = self.make_conversion(
            action_class.Result, encode_func=encode_func, eager=encode_func is None
        )
        self.feedback_conversion = self.make_conversion(action_class.Feedback)
        self.goal_count = 0
        # A goal ends once: its handler's end and the shutdown's abort (close) never interleave.
        self._ending = threading.Lock()
        self._abort_reasons = AbortReasonPublisher(node.ros_node, conn_name)
        try:
            self.server = RetainingActionServer(
                node.ros_node,
                action_class,
                conn_name,
                execute_callback=self._execute,
                goal_callback=lambda _goal: GoalResponse.ACCEPT,
                cancel_callback=lambda _request: CancelResponse.ACCEPT,
                callback_group=self.callback_group,
                goal_service_qos_profile=REQUESTS,
                result_service_qos_profile=REQUESTS,
                cancel_service_qos_profile=REQUESTS,
                result_timeout=result_timeout,
                result_cache_seconds=result_cache_seconds,
            )
        except BaseException:
            # The agent is not added (rcl refused e.g. a negative result_timeout): its reason
            # publisher would stay on the graph, owned by nothing, until the node ends.
            self._abort_reasons.destroy(node.ros_node)
            raise

    def _execute(self, goal_handle: Any) -> Any:
        self.goal_count += 1
        where = "decode"
        try:
            goal = self.goal_conversion.decode_checked(goal_handle.request)
            self._latest = goal
            if self.do_log_msg:
                self.log_msg(goal)
            where = "response_func"
            publisher = None
            if self._wants_feedback_publisher:
                publisher = FeedbackPublisher(goal_handle, self.feedback_conversion.encode)
            try:
                if publisher is None:
                    outcome = self.call_user_and_wait(self._handler, goal)
                else:
                    outcome = self.call_user_and_wait(self._handler, goal, publisher)
                if inspect.isgenerator(outcome) or inspect.isasyncgen(outcome):
                    # A generator's body runs only now: its publish_feedback stays open till
                    # its end.
                    finished, outcome = self._run_generator(outcome, goal_handle)
                    if not finished:
                        self._end(goal_handle, goal_handle.canceled)
                        return self._result_class()
            finally:
                if publisher is not None:
                    publisher.close()
            where = "encode"
            result = (
                self._result_class()
                if outcome is None
                else self.result_conversion.encode(outcome)[0]
            )
            if goal_handle.is_cancel_requested:
                self._end(goal_handle, goal_handle.canceled)
            else:
                if outcome is None:  # a canceled goal's result says nothing: no warning there
                    self.warn_of_default_answer(self._result_class)
                self._end(goal_handle, goal_handle.succeed)
            return result
        except (SystemExit, KeyboardInterrupt) as error:
            # A handler's sys.exit(): the goal is aborted with it, then the node shuts down, as
            # for any callback's (pyconnect.ros.agent_executor); rclpy's Task would let it end
            # the executor thread that runs the goal.
            self.report_exception(where, error)
            text = f"{type(error).__name__}: {error}"
            self._end(goal_handle, lambda: self._abort(goal_handle, text))
            self.node.shutdown()
            return error_message(self._result_class, text)
        except Exception as error:
            self.report_exception(where, error)
            if isinstance(error, CancelledByShutdown):  # an ``async def`` handler
                text = SHUTTING_DOWN
            else:
                text = f"{type(error).__name__}: {error}"
            self._end(goal_handle, lambda: self._abort(goal_handle, text))
            return error_message(self._result_class, text)

    def _end(self, goal_handle: Any, end: Callable[[], None]) -> None:
        """Move a goal to its final state, unless it has one already (aborted at shutdown)."""
        with self._ending:
            if goal_handle.is_active:
                end()

    def _abort(self, goal_handle: Any, text: str) -> None:
        # Published before the result is, so a client finds it when the abort arrives.
        self._abort_reasons.publish(goal_handle.goal_id, text)
        goal_handle.abort()

    def _run_generator(self, generator: Any, goal_handle: Any) -> tuple[bool, Any]:
        """Drive a generator handler: (True, result) at its end, (False, None) when canceled.

        An async generator has no return value: its result is its last yield.
        """
        is_async = inspect.isasyncgen(generator)
        last: Any = None
        while True:
            if goal_handle.is_cancel_requested:
                if is_async:
                    self.wait_on_loop(generator.aclose())
                else:
                    generator.close()
                return False, None
            try:
                feedback = self.wait_on_loop(generator.__anext__()) if is_async else next(generator)
            except StopIteration as stop:
                return True, stop.value
            except StopAsyncIteration:
                return True, last
            last = feedback
            if feedback is not None:
                msg, _stamped = self.feedback_conversion.encode(feedback)
                goal_handle.publish_feedback(msg)

    def close(self) -> None:
        # The executor has stopped: rclpy's server would answer nothing more (see
        # pyconnect.ros.retaining_action_server), so goals still running end here.
        for goal_handle in self.server.active_goals():
            try:
                self._end(goal_handle, functools.partial(self._abort, goal_handle, SHUTTING_DOWN))
            except Exception as error:  # e.g. a transition rcl refuses: the others still end
                self.report_exception("abort at shutdown", error)
        self.server.answer_waiting_requests(error_message(self._result_class, SHUTTING_DOWN))
        self.server.destroy()
        self._abort_reasons.destroy(self.node.ros_node)
        super().close()


class FeedbackPublisher:
    """``publish_feedback(value)``: feedback of one goal, callable from any thread."""

    def __init__(self, goal_handle: Any, encode: Callable[[Any], tuple[Any, bool]]) -> None:
        self._goal_handle = goal_handle
        self._encode = encode
        self._lock = threading.Lock()
        self._open = True
        self.published = 0
        """How many feedback messages were published."""

    def __call__(self, value: Any) -> None:
        """Encode ``value`` and publish it as this goal's feedback."""
        msg, _stamped = self._encode(value)
        with self._lock:
            if not self._open:
                raise PyconnectError("publish_feedback: the goal has already finished")
            self._goal_handle.publish_feedback(msg)
            self.published += 1

    @property
    def cancel_requested(self) -> bool:
        """True once a client asked to cancel this goal (the task may stop early)."""
        return bool(self._goal_handle.is_cancel_requested)

    def close(self) -> None:
        """The goal is over: later calls raise instead of publishing for a finished goal."""
        with self._lock:
            self._open = False
