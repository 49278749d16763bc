"""``action_client`` agents: ``send(goal)`` returns the decoded result, ``cancel()`` stops goals.

``send(goal, timeout=None, feedback_func=None)`` blocks until the result and returns it through
``reform_response``: a dict result gets ``'isdone': True``; an aborted, canceled or rejected
goal, a timeout or a missing server gives ``{'isdone': False, 'error': ...}`` (plus the result's
fields when it is a dict). The abort text comes from the result's ``message``/``error`` field
when the server put one there, else from the reason a pyconnect server publishes beside the
action (pyconnect.ros.abort_reasons). ``block=False`` returns a
``concurrent.futures.Future``. A timeout cancels the goal. ``feedback_func(value)`` gets each
decoded feedback; the latest is also in ``last_feedback``.

Callbacks, as options of the agent (each may be ``async def``; errors are reported like any
callback's): ``accepted_func(accepted: bool)`` when the server accepts or rejects a goal,
``feedback_func(value)`` for every feedback (``send(feedback_func=...)`` overrides it for one
goal), and ``response_func(result)`` with exactly the value ``send()`` returns (or its future
resolves to), failures included, once per goal. ``await send_async(goal)`` is ``send`` for
asyncio code; there (an ``async def`` handler, a coroutine on ``CustomNode(loop=...)``'s loop) a
blocking ``send`` raises a ``PyconnectError``: the loop's thread would wait for a result that may
need the loop.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import asyncio
import concurrent.futures
import threading
from typing import Any

from action_msgs.msg import GoalStatus
from rclpy.callback_groups import CallbackGroup
from rclpy.task import Future as RosFuture

from pyconnect.errors import PyconnectError
from pyconnect.ros.abort_reasons import AbortReasons
from pyconnect.ros.agent_host import AgentHost
from pyconnect.ros.conversion import DecodeFunc, EncodeFunc
from pyconnect.ros.error_fields import error_text_of
from pyconnect.ros.interfaces import interface_class
from pyconnect.ros.node_agent import NodeAgent, ResponseFunc
from pyconnect.ros.option_checks import call_timeout, timeout_problem
from pyconnect.ros.pending_calls import PendingCalls
from pyconnect.ros.qos import REQUESTS
from pyconnect.ros.race_free_action_client import RaceFreeActionClient
from pyconnect.ros.waiting import settle, wait_until


class ActionClientAgent(NodeAgent):
    """Sends goals to the action ``conn_name``."""

    conn_type = "action_client"

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
        accepted_func: ResponseFunc | None = None,
        feedback_func: ResponseFunc | None = None,
        do_log_msg: bool = False,
        timeout: float | None = None,
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
            callback_group=callback_group,
        )
        problem = timeout_problem(timeout)
        if problem is not None:
            raise self.error(problem)
        self.timeout = timeout
        self.accepted_func = accepted_func
        self.feedback_func = feedback_func
        self.goal_conversion = self.make_conversion(
            action_class.Goal, encode_func=encode_func, eager=encode_func is None
        )
        self.result_conversion = self.make_conversion(
            action_class.Result, decode_func=decode_func, eager=decode_func is None
        )
        self.feedback_conversion = self.make_conversion(action_class.Feedback)
        self.last_feedback: Any = None
        self._in_flight: dict[int, _GoalInFlight] = {}
        self._lock = threading.Lock()
        self._server_seen = False
        self.client = RaceFreeActionClient(
            node.ros_node,
            action_class,
            conn_name,
            callback_group=self.callback_group,
            goal_service_qos_profile=REQUESTS,
            result_service_qos_profile=REQUESTS,
            cancel_service_qos_profile=REQUESTS,
        )
        try:
            self._abort_reasons = AbortReasons(node.ros_node, conn_name)
        except BaseException:
            # The agent is not added: its action client would stay on the graph, owned by
            # nothing, until the node ends.
            self.client.destroy()
            raise
        self._pending = PendingCalls(
            node,
            agent_name=self.name,
            during="goal",
            server_ready=self.client.server_is_ready,
            failed=self._failed,
        )

    def is_connected(self) -> bool:
        ready: bool = self.client.server_is_ready()
        return ready

    def send(
        self,
        data: Any = None,
        *,
        timeout: float | None = None,
        feedback_func: ResponseFunc | None = None,
        block: bool = True,
    ) -> Any:
        """Send a goal; the decoded result (or a future of it) through ``reform_response``."""
        timeout = call_timeout(timeout, self.timeout, where=f"{self.describe}: send")
        self._check_call_options("send", feedback_func=feedback_func, block=block)
        if block:
            self.refuse_to_block_on_loop("send()")
        feedback_func = self.feedback_func if feedback_func is None else feedback_func
        goal, _stamped = self.goal_conversion.encode(data)
        if self.do_log_msg:
            self.log_msg(data)
        result: concurrent.futures.Future[Any] = concurrent.futures.Future()
        done = threading.Event()
        result.add_done_callback(lambda _future: done.set())
        if not block:
            if self.response_func is not None:
                result.add_done_callback(self._respond_with_future)
            self._pending.start(
                result,
                lambda future: self._send_goal(goal, future, feedback_func),
                timeout=timeout,
                missing=f"no action server for {self.conn_name}",
                late=f"no result within {timeout} s (goal canceled)",
            )
            return result
        try:
            return self._send_and_wait(goal, result, done, feedback_func, timeout)
        except Exception:
            if not self.node.shutdown_event.is_set():
                raise
            # The node was destroyed under the call (a user thread racing shutdown).
            return self._respond(
                self._failed(f"node {self.node.qualified_name!r} shut down during the goal")
            )

    def _send_and_wait(
        self,
        goal: Any,
        result: concurrent.futures.Future[Any],
        done: threading.Event,
        feedback_func: ResponseFunc | None,
        timeout: float | None,
    ) -> Any:
        if self.node.shutdown_event.is_set():
            return self._respond(self._failed(f"node {self.node.qualified_name!r} is shut down"))
        # Asking the graph is slow; once seen, a lost server shows up as a timeout instead.
        if not self._server_seen:
            if not wait_until(self.client.server_is_ready, timeout, stop=self.node.shutdown_event):
                return self._respond(
                    self._failed(
                        self.why_no_answer(
                            f"no action server for {self.conn_name}", timeout, during="goal"
                        )
                    )
                )
            self._server_seen = True
        in_flight = self._send_goal(goal, result, feedback_func)
        if not self.node.wait_for(done, timeout):
            in_flight.cancel()
            self._server_seen = False
            text = self.why_no_answer("no result", timeout, during="goal")
            return self._respond(self._failed(f"{text} (goal canceled)"))
        return self._respond(result.result())

    async def send_async(
        self,
        data: Any = None,
        *,
        timeout: float | None = None,
        feedback_func: ResponseFunc | None = None,
    ) -> Any:
        """``send(goal)`` awaited on the caller's asyncio loop; a timeout cancels the goal."""
        timeout = call_timeout(timeout, self.timeout, where=f"{self.describe}: send_async")
        self._check_call_options("send_async", feedback_func=feedback_func, block=False)
        future = self.send(data, timeout=timeout, feedback_func=feedback_func, block=False)
        # One timer, the goal's own (PendingCalls answers a late goal as failed and cancels it,
        # and response_func gets that answer): a second one here raced it, and response_func
        # saw a goal that timed out twice. The awaiting task's cancellation cancels the goal.
        return await asyncio.wrap_future(future)

    def _check_call_options(self, where: str, *, feedback_func: object, block: object) -> None:
        """Refuse a call's wrong ``feedback_func`` or ``block`` before its goal goes out (the
        agent's options are checked when it is added): a string ``feedback_func`` sent the goal
        and then failed at every feedback, and ``block="no"`` blocked."""
        if feedback_func is not None and not callable(feedback_func):
            hint = (
                "; pass the function itself, not its name" if isinstance(feedback_func, str) else ""
            )
            raise PyconnectError(
                f"{self.describe}: {where}: feedback_func: expected a callable or None, "
                f"got {type(feedback_func).__name__} {feedback_func!r}{hint}"
            )
        if not isinstance(block, bool):
            raise PyconnectError(
                f"{self.describe}: {where}: block: expected bool, "
                f"got {type(block).__name__} {block!r}"
            )

    def _respond(self, value: Any) -> Any:
        """Hand ``send()``'s return value to ``response_func`` too, and return it."""
        if self.response_func is not None:
            self.call_user("response_func", self.response_func, value)
        return value

    def _respond_with_future(self, future: concurrent.futures.Future[Any]) -> None:
        if self.response_func is None or future.cancelled():
            return
        error = future.exception()
        if error is not None:
            self.report_exception("send", error)
            return
        self.call_user("response_func", self.response_func, future.result())

    def cancel(self) -> int:
        """Cancel every goal of this agent in flight (accepted or not yet); how many."""
        with self._lock:
            goals = list(self._in_flight.values())
        for goal in goals:
            goal.cancel()
        # Goals still waiting for their server are never sent (they ran once it appeared).
        return len(goals) + self._pending.fail_waiting("goal canceled before it was sent")

    # -- goal life cycle ---------------------------------------------------------------------
    def _failed(self, text: str, partial: Any = None) -> Any:
        value = self.reform_response(partial, error=f"{self.describe}: {text}")
        self._latest = value
        return value

    def _send_goal(
        self,
        goal: Any,
        result: concurrent.futures.Future[Any],
        feedback_func: ResponseFunc | None,
    ) -> _GoalInFlight:
        """Send ``goal``; ``result`` gets the outcome (cancelling ``result`` cancels the goal)."""
        in_flight = _GoalInFlight()
        key = id(in_flight)
        with self._lock:
            self._in_flight[key] = in_flight

        def cancel_if_cancelled(_result: concurrent.futures.Future[Any]) -> None:
            # An awaiting caller gave up (its timeout, its task cancelled), or the result is late.
            if result.cancelled() or self._pending.is_late(result):
                in_flight.cancel()

        result.add_done_callback(cancel_if_cancelled)

        def on_feedback(feedback_msg: Any) -> None:
            try:
                value = self.feedback_conversion.decode_checked(feedback_msg.feedback)
            except Exception as error:
                self.report_exception("feedback decode", error)
                return
            self.last_feedback = value
            if feedback_func is not None:
                self.call_user("feedback_func", feedback_func, value)

        def on_goal_response(goal_future: RosFuture) -> None:
            handle = goal_future.result()
            accepted = handle is not None and bool(handle.accepted)
            if self.accepted_func is not None:
                self.call_user("accepted_func", self.accepted_func, accepted)
            if not accepted:
                with self._lock:
                    self._in_flight.pop(key, None)
                settle(result, lambda: self._failed("goal rejected by the server"))
                return
            in_flight.accepted(handle)
            handle.get_result_async().add_done_callback(
                lambda result_future: on_result(result_future, handle.goal_id)
            )

        def on_result(result_future: RosFuture, goal_id: Any) -> None:
            with self._lock:
                self._in_flight.pop(key, None)
            settle(result, lambda: self._outcome(result_future.result(), goal_id))

        self.client.send_goal_async(goal, feedback_callback=on_feedback).add_done_callback(
            on_goal_response
        )
        return in_flight

    def _outcome(self, response: Any, goal_id: Any) -> Any:
        status = response.status
        if status == GoalStatus.STATUS_SUCCEEDED:
            try:
                decoded = self.result_conversion.decode_checked(response.result)
            except Exception as error:  # a failed goal like any other: response_func sees it
                self.report_exception("decode", error)
                reason = str(error).removeprefix(f"{self.describe}: ")  # named once, by _failed
                return self._failed(f"could not decode the result: {reason}")
            value = self.reform_response(decoded)
            self._latest = value
            return value
        try:
            partial = self.result_conversion.decode(response.result)
        except Exception:
            partial = None
        if status == GoalStatus.STATUS_CANCELED:
            return self._failed("goal canceled", partial)
        if status == GoalStatus.STATUS_ABORTED:
            text = error_text_of(response.result) or self._abort_reasons.wait_for_reason(
                goal_id, self.node.wait_for
            )
            return self._failed(
                f"goal aborted by the server: {text}" if text else "goal aborted by the server",
                partial,
            )
        return self._failed(f"goal ended with status {status}", partial)

    def close(self) -> None:
        self._pending.fail_all()
        self.client.destroy()
        self._abort_reasons.destroy(self.node.ros_node)
        super().close()


class _GoalInFlight:
    """A sent goal: its handle once accepted, and whether a cancel was asked before that."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._handle: Any = None
        self._cancel_asked = False

    def accepted(self, handle: Any) -> None:
        with self._lock:
            self._handle = handle
            cancel = self._cancel_asked
        if cancel:
            handle.cancel_goal_async()

    def cancel(self) -> None:
        with self._lock:
            handle = self._handle
            self._cancel_asked = True
        if handle is not None:
            handle.cancel_goal_async()
