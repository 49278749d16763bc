"""A peer's ``action_client`` agent: ``send(goal)`` returns the decoded result, ``cancel()``.

The same contract as ``CustomNode``'s action client (pyconnect.ros.action_client_agent):
``send(goal, timeout=None, feedback_func=None, block=True)`` blocks until the result and returns
it through ``reform_response`` (a dict result gets ``'isdone': True``); a rejected, canceled or
aborted goal, a missing or vanished server (only servers of the client's action type and
RIHS01 hashes count; one of another type fails the goal at once, naming both), a timeout or
the shutdown of the client's peer
(``"... peer '<name>' is shut down"``, before or during the call) give ``{'isdone': False,
'error': ...}`` (plus the result's fields when it is a dict). A timeout cancels the goal.
``block=False`` returns a ``concurrent.futures.Future``; cancelling it cancels the goal (sent
or not yet) and ``response_func`` does not see its outcome. ``accepted_func(accepted)``,
``feedback_func(value)`` and ``response_func(value)`` are called as there (an ``async def`` one
is awaited); the latest feedback is ``last_feedback``.

The protocol is rcl_action's (action_wire): a ``send_goal`` call with a fresh goal id, then a
``get_result`` call that the server answers when the goal ends; feedback arrives on the
feedback topic, tagged with the goal id.
"""

from __future__ import annotations

import collections
import concurrent.futures
import contextlib
import threading
import time
import uuid
from typing import Any

from pyconnect.errors import PyconnectError
from pyconnect.ros.option_checks import call_timeout, timeout_problem
from pyconnect.transport import action_wire as aw
from pyconnect.transport.async_handlers import settle
from pyconnect.transport.conversion import DecodeFunc, EncodeFunc
from pyconnect.transport.endpoints import Caller, CallFailed, Reader
from pyconnect.transport.interface_types import action_interface, message_interface
from pyconnect.transport.peer_agent import Peer, PeerAgent, ResponseFunc, reform_response

CANCEL_CALL_SECONDS = 10.0
REASON_WAIT_SECONDS = 2.0
_KEPT_REASONS = 256
_KEPT_FINISHED = 64


class _GoalInFlight:
    """A sent goal: its id, its feedback function, and whether a cancel was asked."""

    def __init__(self, goal_id: bytes, feedback_func: ResponseFunc | None) -> None:
        self.goal_id = goal_id
        self.feedback_func = feedback_func
        self.accepted = False
        self.cancel_asked = False


class ActionClientAgent(PeerAgent):
    """Sends goals to the action ``conn_name``."""

    conn_type = "action_client"

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
        accepted_func: ResponseFunc | None = None,
        feedback_func: ResponseFunc | None = None,
        timeout: float | None = None,
    ) -> None:
        interface = action_interface(data_interface)
        super().__init__(
            peer,
            conn_name=conn_name,
            agent_name=agent_name,
            type_name=interface.type_name,
            response_func=response_func,
        )
        problem = timeout_problem(timeout)
        if problem is not None:
            raise self.error(problem)
        self.interface = interface
        self.timeout = timeout
        self.accepted_func = accepted_func
        self.feedback_func = feedback_func
        self.goal_conversion = self.wire_conversion(interface.goal, encode_func=encode_func)
        self.result_conversion = self.wire_conversion(interface.result, decode_func=decode_func)
        self.feedback_conversion = self.wire_conversion(interface.feedback)
        self.last_feedback: Any = None
        self.last_status: dict[bytes, int] = {}
        """The latest status the server published for each goal id it lists."""
        self._in_flight: dict[bytes, _GoalInFlight] = {}
        self._queued: dict[bytes, _GoalInFlight] = {}
        """Goals waiting for the server to appear: ``cancel()`` cancels them too."""
        # Feedback travels apart from the result and may arrive after it: recently finished
        # goals still get theirs.
        self._finished: collections.OrderedDict[bytes, _GoalInFlight] = collections.OrderedDict()
        self._reasons: dict[str, str] = {}
        self._reason_arrived = threading.Condition(threading.Lock())
        self._lock = threading.Lock()
        reasons = message_interface(aw.ABORT_REASON_TYPE)
        self._reason_codec = reasons.codec
        name = self.topic
        self._send_goal = Caller(peer, aw.part_name(name, aw.SEND_GOAL), interface.send_goal)
        self._cancel_goal = Caller(peer, aw.part_name(name, aw.CANCEL_GOAL), interface.cancel_goal)
        self._get_result = Caller(peer, aw.part_name(name, aw.GET_RESULT), interface.get_result)
        thread = f"action-{self.name}"
        self._readers = [
            Reader(peer, aw.part_name(name, aw.FEEDBACK), interface.feedback_message,
                   self._on_feedback, thread_name=f"{thread}-feedback"),
            Reader(peer, aw.part_name(name, aw.STATUS), interface.status, self._on_status,
                   depth=1, durability="transient_local", thread_name=f"{thread}-status"),
            Reader(peer, aw.part_name(name, aw.ABORT_REASON), reasons, self._on_reason, depth=32,
                   durability="transient_local", thread_name=f"{thread}-reason"),
        ]  # fmt: skip

    # -- connection ----------------------------------------------------------------------------
    def _server_ready(self) -> bool:
        return all(c.server_count > 0 for c in (self._send_goal, self._get_result))

    def is_connected(self) -> bool:
        return self._server_ready()

    def _type_mismatch(self) -> str | None:
        """Set when the action has servers, but only of other types (or hashes): they would
        never see this client's goals."""
        for caller in (self._send_goal, self._get_result):
            mismatch = caller.type_mismatch()
            if mismatch is not None:
                return f"action {self.topic}: {mismatch}"
        return None

    def waiting_for(self) -> str:
        return self._type_mismatch() or "no action server now"

    # -- sending -------------------------------------------------------------------------------
    def get(self, data: Any = None, show_info: bool = False) -> Any:  # type: ignore[override]
        """The latest result (what the last ``send`` returned); None before any."""
        return super().get(show_info)

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
        feedback_func = self.feedback_func if feedback_func is None else feedback_func
        goal = aw.nested(self.interface.goal, self.goal_conversion.encode(data))
        in_flight = _GoalInFlight(uuid.uuid4().bytes, feedback_func)
        if block:
            return self._respond(self._run_goal(in_flight, goal, timeout))
        result: concurrent.futures.Future[Any] = concurrent.futures.Future()

        def cancel_if_cancelled(future: concurrent.futures.Future[Any]) -> None:
            # The caller gave up, as on a CustomNode: the goal is canceled, its result dropped.
            if future.cancelled():
                self._cancel_goals([in_flight], wait=False)

        def run() -> None:
            # The caller may cancel the future at any moment: it then stays cancelled, and
            # response_func does not see the outcome nobody asked for any more.
            try:
                value = self._run_goal(in_flight, goal, timeout)
                if not result.cancelled():
                    value = self._respond(value)
            except Exception as error:
                self.report_exception("send", error)
                with contextlib.suppress(concurrent.futures.InvalidStateError):
                    result.set_exception(error)
                return
            except BaseException as error:  # sys.exit() in accepted_func or response_func
                self.exit_requested("send", error)
                with contextlib.suppress(concurrent.futures.InvalidStateError):
                    result.set_exception(
                        PyconnectError(f"{self.describe}: a handler raised {error!r}")
                    )
                return
            with contextlib.suppress(concurrent.futures.InvalidStateError):
                result.set_result(value)

        result.add_done_callback(cancel_if_cancelled)
        threading.Thread(target=run, name=f"pyconnect-{self.name}-goal", daemon=True).start()
        return result

    def _respond(self, value: Any) -> Any:
        self._latest = value
        if self.response_func is not None:
            try:
                settle(self.response_func(value))
            except Exception as error:
                self.report_exception("response_func", error)
        return value

    def _run_goal(
        self, in_flight: _GoalInFlight, goal: dict[str, Any], timeout: float | None
    ) -> Any:
        deadline = None if timeout is None else time.monotonic() + timeout

        def can_send() -> bool:
            return (
                in_flight.cancel_asked or self._server_ready() or self._type_mismatch() is not None
            )

        with self._lock:
            self._queued[in_flight.goal_id] = in_flight
        try:
            if not self.peer.wait_for_graph(can_send, deadline):
                return self._failed(
                    self.why_no_answer(f"no action server for {self.conn_name}", timeout)
                )
        finally:
            with self._lock:
                self._queued.pop(in_flight.goal_id, None)
        with self._lock:
            if in_flight.cancel_asked:  # canceled before it was sent: it never will be
                return self._failed("goal canceled")
        mismatch = None if self._server_ready() else self._type_mismatch()
        if mismatch is not None:  # the goal would go nowhere: say why rather than wait
            return self._failed(mismatch)
        with self._lock:
            self._in_flight[in_flight.goal_id] = in_flight
        try:
            return self._goal_outcome(in_flight, goal, deadline, timeout)
        finally:
            with self._lock:
                self._in_flight.pop(in_flight.goal_id, None)
                self._finished[in_flight.goal_id] = in_flight
                while len(self._finished) > _KEPT_FINISHED:
                    self._finished.popitem(last=False)

    def _goal_outcome(
        self,
        in_flight: _GoalInFlight,
        goal: dict[str, Any],
        deadline: float | None,
        timeout: float | None,
    ) -> Any:
        goal_id = {"uuid": in_flight.goal_id}
        codecs = self.interface
        request = codecs.send_goal.request.from_dict({"goal_id": goal_id, "goal": goal})
        try:
            answer = codecs.send_goal.response.to_dict(self._send_goal.call(request, deadline))
        except CallFailed as failure:
            return self._failed(self._call_failure(failure, timeout))
        except Exception as error:  # a malformed answer: a failed send, as any other
            return self._undecodable("the goal response", error)
        accepted = bool(answer["accepted"])
        if self.accepted_func is not None:
            try:
                settle(self.accepted_func(accepted))
            except Exception as error:
                self.report_exception("accepted_func", error)
        if not accepted:
            return self._failed("goal rejected by the server")
        with self._lock:
            in_flight.accepted = True
            cancel = in_flight.cancel_asked
        if cancel:
            self._request_cancel(in_flight.goal_id)
        request = codecs.get_result.request.from_dict({"goal_id": goal_id})
        try:
            response = self._get_result.call(request, deadline)
        except CallFailed as failure:
            if not self.peer.ok():  # no cancel: this peer can no longer send one
                return self._failed(self.why_no_answer("no result", timeout))
            if failure.timed_out or (deadline is not None and time.monotonic() >= deadline):
                self._request_cancel(in_flight.goal_id)
                return self._failed(f"no result within {timeout} s (goal canceled)")
            return self._failed(str(failure))
        try:
            return self._outcome(response, in_flight.goal_id)
        except Exception as error:
            return self._undecodable("the result", error)

    def _undecodable(self, what: str, error: Exception) -> Any:
        self.report_exception("decode", error)
        reason = str(error).removeprefix(f"{self.describe}: ")  # named once, by _failed
        return self._failed(f"could not decode {what}: {reason}")

    def _call_failure(self, failure: CallFailed, timeout: float | None) -> str:
        if not self.peer.ok():
            return self.why_no_answer("no response from the action server", timeout)
        if failure.timed_out:
            return f"no response from the action server within {timeout} s"
        return str(failure)

    def _outcome(self, response: bytes, goal_id: bytes) -> Any:
        fields = self.interface.get_result.response.to_dict(response)
        status = int(fields["status"])
        result_cdr = self.interface.result.from_dict(fields["result"])
        if status == aw.SUCCEEDED:
            return reform_response(self.result_conversion.decode(result_cdr))
        try:
            partial = self.result_conversion.decode(result_cdr)
        except Exception:
            partial = None
        if status == aw.CANCELED:
            return self._failed("goal canceled", partial)
        if status == aw.ABORTED:
            text = aw.error_text(fields["result"]) or self._wait_for_reason(goal_id.hex())
            reason = f"goal aborted by the server: {text}" if text else "goal aborted by the server"
            return self._failed(reason, partial)
        return self._failed(f"goal ended with status {status}", partial)

    def _failed(self, text: str, partial: Any = None) -> Any:
        return reform_response(partial, error=f"{self.describe}: {text}")

    # -- canceling -----------------------------------------------------------------------------
    def cancel(self) -> int:
        """Cancel every goal of this agent in flight (accepted or not yet); how many."""
        with self._lock:
            goals = [*self._queued.values(), *self._in_flight.values()]
        self._cancel_goals(goals, wait=True)
        return len(goals)

    def _cancel_goals(self, goals: list[_GoalInFlight], *, wait: bool) -> None:
        """Ask the server to cancel the accepted ones; the others are canceled when accepted
        (or never sent). ``wait=False``: the requests go from a thread of their own."""
        with self._lock:
            for goal in goals:
                goal.cancel_asked = True
            # A goal that ended is no longer in flight: nothing to cancel.
            accepted = [g.goal_id for g in goals if g.accepted and g.goal_id in self._in_flight]
        if not accepted:
            return
        if wait:
            for goal_id in accepted:
                self._request_cancel(goal_id)
            return

        def request_cancels() -> None:
            for goal_id in accepted:
                try:
                    self._request_cancel(goal_id)
                except Exception as error:  # nobody waits for this thread: say what happened
                    self.report_exception("cancel", error)

        threading.Thread(
            target=request_cancels, name=f"pyconnect-{self.name}-cancel", daemon=True
        ).start()

    def _request_cancel(self, goal_id: bytes) -> None:
        request = self.interface.cancel_goal.request.from_dict(
            {"goal_info": {"goal_id": {"uuid": goal_id}}}
        )
        try:
            self._cancel_goal.call(request, time.monotonic() + CANCEL_CALL_SECONDS)
        except CallFailed as failure:
            self.last_error = f"{self.describe}: cancel failed: {failure}"

    # -- topics --------------------------------------------------------------------------------
    def _on_feedback(self, payload: bytes) -> None:
        try:
            fields = self.interface.feedback_message.codec.to_dict(payload)
            with self._lock:
                goal_id = bytes(fields["goal_id"]["uuid"])
                in_flight = self._in_flight.get(goal_id) or self._finished.get(goal_id)
            if in_flight is None:
                return  # another client's goal
            feedback = self.interface.feedback.from_dict(fields["feedback"])
            value = self.feedback_conversion.decode(feedback)
        except Exception as error:
            self.report_exception("feedback decode", error)
            return
        self.last_feedback = value
        if in_flight.feedback_func is not None:
            try:
                settle(in_flight.feedback_func(value))
            except Exception as error:
                self.report_exception("feedback_func", error)
            except BaseException as error:  # sys.exit() on the reader's thread
                self.exit_requested("feedback_func", error)

    def _on_status(self, payload: bytes) -> None:
        try:
            fields = self.interface.status.codec.to_dict(payload)
        except Exception as error:
            self.report_exception("status decode", error)
            return
        self.last_status = {
            bytes(item["goal_info"]["goal_id"]["uuid"]): int(item["status"])
            for item in fields["status_list"]
        }

    def _on_reason(self, payload: bytes) -> None:
        try:
            fields = self._reason_codec.to_dict(payload)
        except Exception as error:
            self.report_exception("abort reason decode", error)
            return
        with self._reason_arrived:
            self._reasons[str(fields["key"])] = str(fields["value"])
            while len(self._reasons) > _KEPT_REASONS:
                del self._reasons[next(iter(self._reasons))]
            self._reason_arrived.notify_all()

    def _wait_for_reason(self, key: str) -> str:
        deadline = time.monotonic() + REASON_WAIT_SECONDS
        with self._reason_arrived:
            while key not in self._reasons:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    return ""
                self._reason_arrived.wait(remaining)
            return self._reasons.pop(key)

    def close(self) -> None:
        for caller in (self._send_goal, self._cancel_goal, self._get_result):
            caller.close()
        for reader in self._readers:
            reader.close()
