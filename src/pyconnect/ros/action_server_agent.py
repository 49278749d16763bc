"""``action_server`` agents: ``response_func(goal) -> result``, generators publish feedback.

A generator ``response_func`` publishes each yielded value as feedback and its ``return``
value is the result. A cancel request is honoured between two yields: the generator is closed
(its ``finally`` blocks run) and the goal ends canceled. A plain function cannot be stopped;
if a cancel arrived meanwhile, the goal ends canceled when it returns.

A handler that raises aborts the goal *with the error text*: rclpy's own server logs the
exception and sends a default result (rclpy#1020), so this agent catches it, aborts, and puts
``"<Exception>: <text>"`` in the result's first string field named ``message``, ``error``,
``error_message``... (pyconnect.ros.error_fields). Result types without such a field (e.g.
``test_msgs/action/Fibonacci``) cannot carry text, so the reason is also published beside the
action's topics (pyconnect.ros.abort_reasons), where pyconnect clients read it.

Finished goals leave the server's goal list after ``result_timeout`` seconds (default 0.05 s
instead of rclpy's 900 s): every status message lists every goal kept and every client
converts that list to Python objects several times per goal, so latency grows with the number
kept (ROS-FACTS.md: 1.5 -> 13 ms over 500 goals). Their results stay available
``result_cache_seconds`` (60 s) for late ``get_result`` requests
(pyconnect.ros.retaining_action_server).
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import inspect
from typing import Any

from rclpy.action import CancelResponse, GoalResponse
from rclpy.callback_groups import CallbackGroup, ReentrantCallbackGroup

from pyconnect.ros.abort_reasons import AbortReasonPublisher
from pyconnect.ros.agent_host import AgentHost
from pyconnect.ros.conversion import DecodeFunc, EncodeFunc
from pyconnect.ros.error_fields import error_message
from pyconnect.ros.interfaces import interface_class
from pyconnect.ros.node_agent import NodeAgent, ResponseFunc
from pyconnect.ros.retaining_action_server import RetainingActionServer

DEFAULT_RESULT_TIMEOUT = 0.05
"""Seconds a finished goal stays in the server's goal list (and every status message)."""

DEFAULT_RESULT_CACHE_SECONDS = 60.0
"""Seconds a late ``get_result`` request is still answered (retaining_action_server)."""


class ActionServerAgent(NodeAgent):
    """Executes goals sent to the action ``conn_name`` with ``response_func``."""

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
        self._result_class = action_class.Result
        self.goal_conversion = self.make_conversion(
            action_class.Goal, decode_func=decode_func, eager=decode_func is None
        )
        self.result_conversion = self.make_conversion(
            action_class.Result, encode_func=encode_func, eager=encode_func is None
        )
        self.feedback_conversion = self.make_conversion(action_class.Feedback)
        self.goal_count = 0
        self._abort_reasons = AbortReasonPublisher(node.ros_node, conn_name)
        self.server = RetainingActionServer(
            node.ros_node,
            action_class,
            conn_name,
            execute_callback=self._execute,
            goal_callback=lambda _goal: GoalResponse.ACCEPT,
            cancel_callback=lambda _request: CancelResponse.ACCEPT,
            callback_group=self.callback_group,
            result_timeout=result_timeout,
            result_cache_seconds=result_cache_seconds,
        )

    def _execute(self, goal_handle: Any) -> Any:
        self.goal_count += 1
        where = "decode"
        try:
            goal = self.goal_conversion.decode_checked(goal_handle.request)
            self._latest = goal
            if self.do_log_msg:
                self.log_msg(goal)
            where = "response_func"
            outcome = self._handler(goal)
            if inspect.isgenerator(outcome):
                finished, outcome = self._run_generator(outcome, goal_handle)
                if not finished:
                    goal_handle.canceled()
                    return self._result_class()
            where = "encode"
            result = (
                self._result_class()
                if outcome is None
                else self.result_conversion.encode(outcome)[0]
            )
            if goal_handle.is_cancel_requested:
                goal_handle.canceled()
            else:
                goal_handle.succeed()
            return result
        except Exception as error:
            self.report_exception(where, error)
            text = f"{type(error).__name__}: {error}"
            if goal_handle.is_active:
                # Published before the result is, so a client finds it when the abort arrives.
                self._abort_reasons.publish(goal_handle.goal_id, text)
                goal_handle.abort()
            return error_message(self._result_class, text)

    def _run_generator(self, generator: Any, goal_handle: Any) -> tuple[bool, Any]:
        """Drive a generator handler: (True, result) at its end, (False, None) when canceled."""
        while True:
            if goal_handle.is_cancel_requested:
                generator.close()
                return False, None
            try:
                feedback = next(generator)
            except StopIteration as stop:
                return True, stop.value
            if feedback is not None:
                msg, _stamped = self.feedback_conversion.encode(feedback)
                goal_handle.publish_feedback(msg)

    def close(self) -> None:
        self.server.destroy()
        self._abort_reasons.destroy(self.node.ros_node)
        super().close()
