"""A peer's ``action_server`` agent: ``response_func(goal) -> result`` on rcl_action's wire.

The same contract as ``CustomNode``'s action server (pyconnect.ros.action_server_agent):
feedback either from a *generator* ``response_func`` (each yield is published; its ``return``
value is the result; a cancel is honoured between yields) or through a second positional
parameter ``publish_feedback`` (callable from any thread; ``publish_feedback.cancel_requested``).
``async def`` functions and generators run on an event loop of the goal's own thread
(pyconnect.transport.async_handlers). Every goal is accepted and runs on its own thread; the
goal, cancel and result services keep every request until it is answered (keep-all). A
handler that raises aborts the goal with ``"<Exception>: <text>"`` in the result's first text
field (``message``, ``error``...) and on the abort-reason topic (action_wire).

Finished goals stay in the status list ``result_timeout`` seconds and answer late
``get_result`` requests ``result_cache_seconds`` seconds, as CustomNode's server does.

At shutdown, as on CustomNode, a goal whose handler returns still succeeds with its result, and
one still running is aborted with ``"server is shutting down"``: a generator at its next yield,
any other once ``close``'s timeout has passed (its thread is not stopped; what it returns later
is dropped). ``cancel_requested`` stays a client's request: a shutdown is not a cancel.
"""

from __future__ import annotations

import inspect
import threading
import time
from typing import Any

from pyconnect.ros.handler_shape import wants_feedback_publisher
from pyconnect.transport import action_wire as aw
from pyconnect.transport.action_goal import FeedbackPublisher, ServerGoal, drive_generator
from pyconnect.transport.async_handlers import agent_loop, cancel_coroutine, settle
from pyconnect.transport.conversion import DecodeFunc, EncodeFunc
from pyconnect.transport.endpoints import Request, Server, Writer
from pyconnect.transport.interface_types import action_interface, message_interface
from pyconnect.transport.peer_agent import Peer, PeerAgent, ResponseFunc

DEFAULT_RESULT_TIMEOUT = 0.05
DEFAULT_RESULT_CACHE_SECONDS = 60.0
RESULT_GRACE = 1.0
"""How long after a goal's end a closing server waits for its result request (a client asks as
soon as its goal is accepted; one that has not asked a second later will not)."""

SHUTTING_DOWN = "server is shutting down"
"""The abort reason of a goal still running at shutdown: CustomNode's text
(pyconnect.ros.service_agents, which this rclpy-free module cannot import)."""


class ActionServerAgent(PeerAgent):
    """Executes goals sent to the action ``conn_name`` with ``response_func``.

    A ``response_func`` whose result is None (no ``return``) succeeds with the default result
    (every field at its default); where the result type has fields, the first such goal logs
    a warning.
    """

    conn_type = "action_server"

    def __init__(
        self,
        peer: Peer,
        *,
        conn_name: str,
        agent_name: str | None = None,
        data_interface: object,
        encode_func: EncodeFunc | None = None,
        decode_func: DecodeFunc | None = None,
        response_func: ResponseFunc | None = None,
        result_timeout: float = DEFAULT_RESULT_TIMEOUT,
        result_cache_seconds: float = DEFAULT_RESULT_CACHE_SECONDS,
    ) -> None:
        interface = action_interface(data_interface)
        super().__init__(
            peer,
            conn_name=conn_name,
            agent_name=agent_name,
            type_name=interface.type_name,
            response_func=response_func,
        )
        if response_func is None:
            raise self.error("an 'action_server' agent needs a response_func")
        self._handler: ResponseFunc = response_func
        self._wants_feedback_publisher = wants_feedback_publisher(response_func)
        self.interface = interface
        self.result_timeout = result_timeout
        self.result_cache_seconds = result_cache_seconds
        self.goal_conversion = self.wire_conversion(interface.goal, decode_func=decode_func)
        self.result_conversion = self.wire_conversion(interface.result, encode_func=encode_func)
        self.feedback_conversion = self.wire_conversion(interface.feedback)
        self.goal_count = 0
        self._goals: dict[bytes, ServerGoal] = {}
        self._running: set[threading.Thread] = set()  # goal threads, joined on close
        self._lock = threading.Lock()
        self._result_asked = threading.Condition(self._lock)
        self._closed = False
        # Set when close begins: generator goals stop at their next yield (aborted, not
        # canceled: no client asked). Apart from cancel_requested, which only clients set.
        self._shutting_down = threading.Event()
        name = self.topic
        self._feedback = Writer(peer, aw.part_name(name, aw.FEEDBACK), interface.feedback_message)
        self._status = Writer(
            peer,
            aw.part_name(name, aw.STATUS),
            interface.status,
            depth=1,
            durability="transient_local",
        )
        self._abort_reasons = Writer(
            peer,
            aw.part_name(name, aw.ABORT_REASON),
            message_interface(aw.ABORT_REASON_TYPE),
            depth=32,
            durability="transient_local",
        )
        thread = f"action-{self.name}"
        self._servers = [
            Server(peer, aw.part_name(name, aw.SEND_GOAL), interface.send_goal, self._on_goal,
                   thread_name=f"{thread}-goal"),
            Server(peer, aw.part_name(name, aw.CANCEL_GOAL), interface.cancel_goal,
                   self._on_cancel, thread_name=f"{thread}-cancel"),
            Server(peer, aw.part_name(name, aw.GET_RESULT), interface.get_result,
                   self._on_result_request, thread_name=f"{thread}-result"),
        ]  # fmt: skip

    # -- requests ------------------------------------------------------------------------------
    def _on_goal(self, request: Request) -> None:
        codecs = self.interface.send_goal
        try:
            fields = codecs.request.to_dict(request.payload)
        except Exception as error:
            self.report_exception("decode", error)
            request.reply(codecs.response.from_dict({"accepted": False, "stamp": aw.stamp_now()}))
            return
        goal_id = bytes(fields["goal_id"]["uuid"])
        stamp = aw.stamp_now()
        with self._lock:
            accepted = not self._closed and goal_id not in self._goals
            if accepted:
                goal = self._goals[goal_id] = ServerGoal(goal_id, stamp)
        request.reply(codecs.response.from_dict({"accepted": accepted, "stamp": stamp}))
        if not accepted:
            return
        self.goal_count += 1
        self._publish_status()
        goal_cdr = self.interface.goal.from_dict(fields["goal"])
        thread = threading.Thread(
            target=self._execute, args=(goal, goal_cdr), name=f"pyconnect-goal-{self.name}",
            daemon=True,
        )  # fmt: skip
        with self._lock:
            self._running.add(thread)
        thread.start()

    def _on_result_request(self, request: Request) -> None:
        codecs = self.interface.get_result
        try:
            goal_id = bytes(codecs.request.to_dict(request.payload)["goal_id"]["uuid"])
        except Exception as error:
            self.report_exception("decode", error)
            goal_id = b""
        with self._lock:
            self._forget_expired()
            goal = self._goals.get(goal_id)
            if goal is not None:
                goal.result_asked = True
                self._result_asked.notify_all()
            if goal is not None and goal.response is None:
                goal.waiting.append(request)  # answered when the goal ends
                return
        if goal is not None and goal.response is not None:
            request.reply(goal.response)
        else:  # rcl_action answers an unknown goal with status UNKNOWN and a default result
            request.reply(codecs.response.from_dict({"status": aw.UNKNOWN}))

    def _on_cancel(self, request: Request) -> None:
        codecs = self.interface.cancel_goal
        try:
            info = codecs.request.to_dict(request.payload)["goal_info"]
        except Exception as error:
            self.report_exception("decode", error)
            request.reply(codecs.response.from_dict({"return_code": aw.CANCEL_REJECTED}))
            return
        goal_id, before = bytes(info["goal_id"]["uuid"]), aw.stamp_ns(info["stamp"])
        any_goal = goal_id == bytes(len(goal_id))
        canceling: list[dict[str, Any]] = []
        with self._lock:
            known = goal_id in self._goals
            for goal in self._goals.values():
                # rcl_action_process_cancel_request: this goal, and every goal accepted at or
                # before a nonzero stamp; a zero id and a zero stamp mean all goals.
                chosen = goal.goal_id == goal_id or (
                    (before != 0 and aw.stamp_ns(goal.stamp) <= before)
                    or (any_goal and before == 0)
                )
                if chosen and goal.status in aw.ACTIVE:
                    goal.status = aw.CANCELING
                    goal.cancel_requested.set()
                    canceling.append({"goal_id": {"uuid": goal.goal_id}, "stamp": goal.stamp})
        if canceling:
            code = aw.CANCEL_NONE
        elif not any_goal and not known:
            code = aw.CANCEL_UNKNOWN_GOAL
        elif not any_goal:
            code = aw.CANCEL_TERMINATED
        else:
            code = aw.CANCEL_REJECTED
        request.reply(
            codecs.response.from_dict({"return_code": code, "goals_canceling": canceling})
        )
        if canceling:
            self._publish_status()

    # -- executing a goal ----------------------------------------------------------------------
    def _execute(self, goal: ServerGoal, goal_cdr: bytes) -> None:
        try:
            with agent_loop():
                self._execute_goal(goal, goal_cdr)
        finally:
            with self._lock:
                self._running.discard(threading.current_thread())

    def _execute_goal(self, goal: ServerGoal, goal_cdr: bytes) -> None:
        with self._lock:
            if goal.status == aw.ACCEPTED:
                goal.status = aw.EXECUTING
        self._publish_status()
        where = "decode"
        try:
            value = self.goal_conversion.decode(goal_cdr)
            self._latest = value
            where = "response_func"
            publisher = FeedbackPublisher(self.publish_feedback, goal)
            try:
                if self._wants_feedback_publisher:
                    outcome = settle(self._handler(value, publisher))
                else:
                    outcome = settle(self._handler(value))
                if inspect.isgenerator(outcome) or inspect.isasyncgen(outcome):
                    finished, outcome = drive_generator(
                        outcome, goal, publisher, self._shutting_down
                    )
                    if not finished:
                        if goal.cancel_requested.is_set():
                            self._end(goal, aw.CANCELED, {})
                        else:  # stopped by the shutdown
                            self._abort(goal, SHUTTING_DOWN)
                        return
            finally:
                publisher.close()
            where = "encode"
            result = {} if outcome is None else self._result_dict(outcome)
            status = aw.CANCELED if goal.cancel_requested.is_set() else aw.SUCCEEDED
            if outcome is None and status == aw.SUCCEEDED:  # a canceled goal's result says nothing
                self.warn_of_default_answer(self.interface.result)
            self._end(goal, status, result)
        except Exception as error:
            self.report_exception(where, error)
            self._abort(goal, f"{type(error).__name__}: {error}")
        except BaseException as error:  # sys.exit() in response_func: abort, then shut down
            cancelled = self.cancelled_by_shutdown(error)
            self._abort(goal, SHUTTING_DOWN if cancelled else f"{type(error).__name__}: {error}")
            self.exit_requested(where, error)

    def _result_dict(self, outcome: Any) -> dict[str, Any]:
        return aw.nested(self.interface.result, self.result_conversion.encode(outcome))

    def publish_feedback(self, goal: ServerGoal, value: Any) -> None:
        feedback = aw.nested(self.interface.feedback, self.feedback_conversion.encode(value))
        message = {"goal_id": {"uuid": goal.goal_id}, "feedback": feedback}
        self._feedback.put(self.interface.feedback_message.codec.from_dict(message))

    def _abort(self, goal: ServerGoal, text: str) -> None:
        """End ``goal`` aborted with ``text`` (the result's text field, the abort-reason topic),
        unless it has ended already."""
        if not self._claim(goal):
            return
        # Published before the result is, so a client finds it when the abort arrives.
        reason = {"key": goal.goal_id.hex(), "value": text}
        try:
            self._abort_reasons.put(self._abort_reasons.codec.from_dict(reason))
        except Exception as error:  # the goal has been claimed: it must still get its result
            self.report_exception("abort reason", error)
        self._finish(goal, aw.ABORTED, aw.error_result(self.interface.result, text))

    def _end(self, goal: ServerGoal, status: int, result: dict[str, Any]) -> None:
        """End ``goal`` with ``status``, unless it has ended already (aborted at shutdown)."""
        if self._claim(goal):
            self._finish(goal, status, result)

    def _claim(self, goal: ServerGoal) -> bool:
        """Whether the caller is the one to end ``goal`` (a goal ends once)."""
        with self._lock:
            claimed, goal.ended = not goal.ended, True
            return claimed

    def _finish(self, goal: ServerGoal, status: int, result: dict[str, Any]) -> None:
        response = self.interface.get_result.response.from_dict(
            {"status": status, "result": result}
        )
        with self._lock:
            goal.status = status
            goal.response = response
            goal.finished_at = time.monotonic()
            waiting, goal.waiting = goal.waiting, []
        self._publish_status(finished=goal)
        for request in waiting:
            try:
                request.reply(response)
            except Exception as error:
                self.report_exception("reply", error)

    def _publish_status(self, *, finished: ServerGoal | None = None) -> None:
        """Publish every goal still listed (``finished``: the goal that just ended, listed
        however long the way here took)."""
        with self._lock:
            self._forget_expired()
            now = time.monotonic()
            listed = [
                {"goal_info": {"goal_id": {"uuid": g.goal_id}, "stamp": g.stamp},
                 "status": g.status}
                for g in self._goals.values()
                if g.response is None
                or g is finished
                or now - g.finished_at <= self.result_timeout
            ]  # fmt: skip
            if self._closed:
                return
            try:
                self._status.put(self._status.codec.from_dict({"status_list": listed}))
            except Exception as error:
                self.report_exception("status", error)

    def _forget_expired(self) -> None:
        now = time.monotonic()
        for goal_id in [
            g.goal_id
            for g in self._goals.values()
            if g.response is not None and now - g.finished_at > self.result_cache_seconds
        ]:
            del self._goals[goal_id]

    def close(self, timeout: float = 5.0) -> None:
        with self._lock:
            self._closed = True
            self._shutting_down.set()
            running = [t for t in self._running if t is not threading.current_thread()]
            active = [goal for goal in self._goals.values() if not goal.ended]
            # A goal that ended just before (a "stop" goal whose handler asked for this
            # shutdown) may not have had its result asked for yet: its request is on its way,
            # waited for ``RESULT_GRACE`` s from the goal's end. One that ended longer ago
            # unasked has a client that does not ask (send_goal_async without the result).
            now = time.monotonic()
            recent = [
                goal
                for goal in self._goals.values()
                if goal.ended and not goal.result_asked and now - goal.finished_at < RESULT_GRACE
            ]
        # Running goals get ``timeout`` seconds to send their result while the session is open
        # (a goal thread left inside zenoh at interpreter exit aborts the process).
        deadline = time.monotonic() + timeout
        for thread in running:
            cancel_coroutine(thread)  # an ``async def`` handler stops now, as on a CustomNode
        for thread in running:
            thread.join(max(0.0, deadline - time.monotonic()))
        with self._lock:
            unfinished = [goal for goal in active if not goal.ended]
        for goal in unfinished:  # their clients hear now instead of waiting their timeout
            try:
                self._abort(goal, SHUTTING_DOWN)
            except Exception as error:  # the others still end
                self.report_exception("abort at shutdown", error)
        # A client asks for the result once its goal is accepted: a goal that ended quickly
        # (a "stop" action shutting its own peer down) may end before that request arrives,
        # and closing the server first would lose the result.
        with self._result_asked:
            self._result_asked.wait_for(
                lambda: all(goal.result_asked for goal in active),
                max(0.0, deadline - time.monotonic()),
            )
            grace = max((goal.finished_at + RESULT_GRACE for goal in recent), default=0.0)
            self._result_asked.wait_for(
                lambda: all(goal.result_asked for goal in recent),
                max(0.0, min(deadline, grace) - time.monotonic()),
            )
        for server in self._servers:
            server.close()
        for writer in (self._feedback, self._status, self._abort_reasons):
            writer.close()
