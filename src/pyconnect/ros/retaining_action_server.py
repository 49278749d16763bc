"""An rclpy ``ActionServer`` that expires goals quickly but still answers late result requests.

Why: every status message of an action lists every goal the server still keeps, and each
client turns that whole array into Python objects several times per goal, so goal latency
grows with the number kept (docs/ros-facts.md: 1.5 -> 13 ms over 500 goals with rclpy's 900 s).
Expiring goals after ``result_timeout`` (pyconnect: 0.05 s) keeps the array short; the results
of expired goals move to a small cache (``result_cache_seconds``, at most ``result_cache_size``
entries) from which a late ``get_result`` request is still answered, instead of rclpy's
STATUS_UNKNOWN. Clients ask for the result right after acceptance, so the cache is rarely used.

Also guards the expiry against the goal-expiry ``KeyError`` race (rclpy#1667): a result request
and the expiry of its goal (on another executor thread) never interleave, and a goal that
expires before rclpy set its result is expired once the result is there. Overrides two private
coroutines of rclpy 7.1's ``ActionServer`` (``_execute_expire_goals``,
``_execute_get_result_request``); the tests pin their behaviour.

At shutdown rclpy's server would drop what it owes: it sends a result from a done callback of
the goal's result future, which it schedules on the executor, and the executor has stopped by
then. So this server keeps the result requests still waiting, and ``answer_waiting_requests``
sends them directly before the server is destroyed: a finished goal's result, or ``ABORTED``
for a goal that is still running (which the agent has aborted by then). A client asks for the
result only once it has the goal's acceptance, so that request may still be on its way (a
handler that shut its node down returns at once): shutdown waits, ``TAKE_FOR_SECONDS`` at most,
until every goal it keeps has been asked for.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined,misc"

from __future__ import annotations

import functools
import threading
import time
from collections import OrderedDict
from typing import Any

from action_msgs.msg import GoalStatus
from rclpy.action import ActionServer
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.task import Future

TAKE_FOR_SECONDS = 0.5
"""How long shutdown goes on taking result requests that were never taken, or waits for those
of kept goals not asked for yet: a flood cannot hold it up, nor clients gone meanwhile (rmw may
wait on each such answer)."""


class RetainingActionServer(ActionServer):
    """``ActionServer`` with short goal retention plus a cache of finished results."""

    def __init__(
        self,
        *args: Any,
        result_cache_seconds: float = 60.0,
        result_cache_size: int = 1000,
        **kwargs: Any,
    ) -> None:
        self._cache_seconds = result_cache_seconds
        self._cache_size = result_cache_size
        self._finished: OrderedDict[bytes, tuple[float, Any]] = OrderedDict()
        self._finished_lock = threading.Lock()
        self._expiry_lock = threading.RLock()
        # Result requests not answered yet, per goal uuid (under ``_expiry_lock``).
        self._waiting: dict[bytes, list[Any]] = {}
        # Kept goals whose result was asked for (under ``_expiry_lock``): shutdown waits for
        # the requests of the others.
        self._asked: set[bytes] = set()
        super().__init__(*args, **kwargs)

    async def _execute_expire_goals(self, expired_goals: Any) -> None:
        self._expire_goals(expired_goals)

    def _expire_goals(self, expired_goals: Any) -> None:
        for goal in expired_goals:
            goal_uuid = bytes(goal.goal_id.uuid)
            with self._expiry_lock:
                future = self._result_futures.get(goal_uuid)
                if future is not None and not future.done():
                    # rclpy marks the goal terminal, then sets its result: with a short
                    # result_timeout the expiry can come in between. Expire it once the result
                    # is there (rclpy would otherwise find its future gone and never answer).
                    future.add_done_callback(lambda _done, key=goal_uuid: self._expire(key))
                    continue
            self._expire(goal_uuid)

    def _expire(self, goal_uuid: bytes) -> None:
        """Drop a finished goal from the server, keeping its result in the cache."""
        # Expiry and result requests run on different executor threads (the server's group is
        # reentrant): the lock makes "goal kept, or result cached" atomic for requests.
        with self._expiry_lock:
            handle = self._goal_handles.pop(goal_uuid, None)
            future = self._result_futures.pop(goal_uuid, None)
            self._asked.discard(goal_uuid)
            if future is not None and future.done():
                self._remember(goal_uuid, future.result(), time.monotonic())
        if handle is not None:
            handle.destroy()
        if future is not None and future in self._futures:  # not after destroy()
            self.remove_future(future)

    async def _execute_get_result_request(self, request_header_and_message: Any) -> None:
        request_header, result_request = request_header_and_message
        goal_uuid = bytes(result_request.goal_id.uuid)
        with self._expiry_lock:
            future = (
                self._result_futures.get(goal_uuid) if goal_uuid in self._goal_handles else None
            )
            cached = None if future is not None else self._recall(goal_uuid)
            if future is not None:
                self._waiting.setdefault(goal_uuid, []).append(request_header)
                self._asked.add(goal_uuid)
        if future is not None:
            future.add_done_callback(functools.partial(self._answer, goal_uuid, request_header))
        elif cached is not None:
            self._send_result(request_header, cached)
        else:
            await super()._execute_get_result_request(request_header_and_message)  # UNKNOWN

    def _answer(self, goal_uuid: bytes, request_header: Any, future: Any) -> None:
        """Send a goal's result to one waiting request, unless shutdown answered it already."""
        with self._expiry_lock:
            if not _take(self._waiting, goal_uuid, request_header):
                return
        self._send_result_response(request_header, future)

    def active_goals(self) -> list[Any]:
        """The goal handles of goals not finished yet."""
        with self._expiry_lock:
            return [handle for handle in self._goal_handles.values() if handle.is_active]

    def answer_waiting_requests(self, unfinished_result: Any) -> int:
        """Answer every result request still waiting (shutdown: the executor that would run
        rclpy's answers has stopped): a finished goal's own result, else ``ABORTED`` with
        ``unfinished_result``. Returns how many requests were answered."""
        answered = self._take_result_requests()
        with self._expiry_lock:
            waiting, self._waiting = self._waiting, {}
            futures = {goal_uuid: self._result_futures.get(goal_uuid) for goal_uuid in waiting}
        for goal_uuid, headers in waiting.items():
            future = futures[goal_uuid]
            if future is not None and future.done():
                response = future.result()
            else:
                response = self._action_type.Impl.GetResultService.Response()
                response.status = GoalStatus.STATUS_ABORTED
                response.result = unfinished_result
            for header in headers:
                self._send_result(header, response)
                answered += 1
        return answered

    def destroy(self) -> None:
        """Destroy the server; a goal still running (its handler left behind at shutdown) may
        end later, and its result then goes nowhere instead of to the shut-down executor."""
        super().destroy()
        with self._expiry_lock:
            for goal_uuid, future in list(self._result_futures.items()):
                if not future.done():
                    # rclpy hands a done future's callbacks to its executor: a fresh future
                    # has no executor and no callbacks (every waiting request is answered).
                    self._result_futures[goal_uuid] = Future()

    def _take_result_requests(self) -> int:
        """Take the result requests that arrived but were never taken (the executor has
        stopped), and wait for those of kept goals not asked for yet (every kept goal has
        ended by now): requests for kept goals wait with the others; the rest are answered here
        as rclpy would (cached result, or ``UNKNOWN``). Returns how many were answered."""
        answered = 0
        deadline = time.monotonic() + TAKE_FOR_SECONDS
        with self._expiry_lock:
            unasked = set(self._goal_handles) - self._asked
        wait_set = None
        while (remaining := deadline - time.monotonic()) > 0:
            with self._lock:
                header, request = self._handle.take_result_request(
                    self._action_type.Impl.GetResultService.Request
                )
            if header is not None and request is not None:
                goal_uuid = bytes(request.goal_id.uuid)
                unasked.discard(goal_uuid)
                answered += self._take_one(goal_uuid, header)
                continue
            if not unasked:
                break
            if wait_set is None:
                wait_set = self._new_wait_set()
            self._wait_and_clear(wait_set, remaining)
        return answered

    def _take_one(self, goal_uuid: bytes, header: Any) -> int:
        """Keep one taken result request of a kept goal, or answer it; 1 if answered."""
        with self._expiry_lock:
            kept = goal_uuid in self._goal_handles
            if kept:
                self._waiting.setdefault(goal_uuid, []).append(header)
                self._asked.add(goal_uuid)
            response = None if kept else self._recall(goal_uuid)
        if kept:
            return 0
        if response is None:
            response = self._action_type.Impl.GetResultService.Response()
            response.status = GoalStatus.STATUS_UNKNOWN
        self._send_result(header, response)
        return 1

    def _new_wait_set(self) -> Any:
        """A wait set for this server's entities alone (its services and expiry timer)."""
        counts = self.get_num_entities()
        return _rclpy.WaitSet(
            counts.num_subscriptions,
            counts.num_guard_conditions,
            counts.num_timers,
            counts.num_clients,
            counts.num_services,
            counts.num_events,
            self._node.context.handle,
        )

    def _wait_and_clear(self, wait_set: Any, seconds: float) -> None:
        """Wait up to ``seconds`` until one of the server's entities is ready, then take what
        is ready but a result request (the caller takes those): else each next wait would
        return at once. A new goal is refused and a cancel request rejected (the server shuts
        down); expired goals leave as usual (their results stay in the cache)."""
        with self._node.context.handle, self._handle:
            wait_set.clear_entities()
            self.add_to_wait_set(wait_set)
            wait_set.wait(int(seconds * 1e9))
            with self._lock:
                goal_ready, cancel_ready, _result_ready, expired = self._handle.is_ready(wait_set)
        impl = self._action_type.Impl
        if goal_ready:
            with self._lock:
                header, _goal = self._handle.take_goal_request(impl.SendGoalService.Request)
            if header is not None:
                self._answer_safely(
                    self._handle.send_goal_response, header, impl.SendGoalService.Response()
                )
        if cancel_ready:
            with self._lock:
                header, _cancel = self._handle.take_cancel_request(impl.CancelGoalService.Request)
            if header is not None:
                refusal = impl.CancelGoalService.Response()
                refusal.return_code = refusal.ERROR_REJECTED
                self._answer_safely(self._handle.send_cancel_response, header, refusal)
        if expired:
            with self._lock:
                expired_goals = self._handle.expire_goals(len(self._goal_handles))
            self._expire_goals(expired_goals)

    def _remember(self, goal_uuid: bytes, response: Any, now: float) -> None:
        with self._finished_lock:
            self._finished[goal_uuid] = (now, response)
            while len(self._finished) > self._cache_size:
                self._finished.popitem(last=False)
            while self._finished:
                oldest_uuid, (stamp, _) = next(iter(self._finished.items()))
                if now - stamp <= self._cache_seconds:
                    break
                del self._finished[oldest_uuid]

    def _recall(self, goal_uuid: bytes) -> Any:
        with self._finished_lock:
            entry = self._finished.get(goal_uuid)
        if entry is None or time.monotonic() - entry[0] > self._cache_seconds:
            return None
        return entry[1]

    def _send_result(self, request_header: Any, response: Any) -> None:
        self._answer_safely(self._handle.send_result_response, request_header, response)

    def _answer_safely(self, send: Any, request_header: Any, response: Any) -> None:
        try:
            send(request_header, response)
        except _rclpy.RCLError:
            self._logger.warn("Failed to send a response (the client may have gone away)")


def _take(waiting: dict[bytes, list[Any]], goal_uuid: bytes, request_header: Any) -> bool:
    """Remove ``request_header`` (this very object) from ``waiting``; False if it is not there."""
    headers = waiting.get(goal_uuid, [])
    for index, header in enumerate(headers):
        if header is request_header:
            del headers[index]
            if not headers:
                del waiting[goal_uuid]
            return True
    return False
