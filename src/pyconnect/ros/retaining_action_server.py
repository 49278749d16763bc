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
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined,misc"

from __future__ import annotations

import functools
import threading
import time
from collections import OrderedDict
from typing import Any

from rclpy.action import ActionServer


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
        super().__init__(*args, **kwargs)

    async def _execute_expire_goals(self, expired_goals: Any) -> None:
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
            if future is not None and future.done():
                self._remember(goal_uuid, future.result(), time.monotonic())
        if handle is not None:
            handle.destroy()
        if future is not None:
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
            future.add_done_callback(functools.partial(self._send_result_response, request_header))
        elif cached is not None:
            self._send_cached(request_header, cached)
        else:
            await super()._execute_get_result_request(request_header_and_message)  # UNKNOWN

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

    def _send_cached(self, request_header: Any, response: Any) -> None:
        from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy

        try:
            self._handle.send_result_response(request_header, response)
        except _rclpy.RCLError:
            self._logger.warn("Failed to send result response (the client may have gone away)")
