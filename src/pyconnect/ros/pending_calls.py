"""A client agent's ``block=False`` calls: started when the server is ready, always answered.

Both client kinds (service, action) hand their non-blocking calls to a ``PendingCalls``: the
call starts at once when the server is ready, else when one thread per agent, alive only while
calls wait for the server, sees it ready (a future that the caller cancels meanwhile is dropped,
and a thread with no call left ends); the node spins in the background from then on, since the
answer needs callbacks to run, as a blocking ``send()`` and ``wait_until_connected`` start it.
``timeout`` holds as for a blocking call: for the server to appear, then for the answer (one
watchdog thread per agent, alive only while calls wait for answers); a late call is answered
with the failure value and ``is_late`` tells the agent to drop its request or cancel its goal.
An answered call is let go at once, not at its deadline: what the agent holds is bounded by the
calls still open. A future still open when the node shuts down gets the failed value, so
nothing waits on it for ever; on a node already shut down the future is failed from the start.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import functools
import heapq
import itertools
import threading
import time
import weakref
from collections.abc import Callable
from typing import Any

from pyconnect.ros.agent_host import AgentHost
from pyconnect.ros.waiting import settle

Call = Callable[[concurrent.futures.Future[Any]], object]
"""Starts the middleware call that will settle the future it is given."""

POLL = 0.02
"""Seconds between two looks at the graph while calls wait for their server (as ``wait_until``)."""

LONGEST_SLEEP = 3600.0
"""The longest the watchdog sleeps at once: a deadline further off is looked at again then
(a sleep past ``threading.TIMEOUT_MAX`` raised ``OverflowError`` and ended the watchdog)."""


class _Waiting:
    """A call not made yet: its server is not ready."""

    __slots__ = ("call", "deadline", "late", "missing", "result", "timeout")

    def __init__(
        self,
        result: concurrent.futures.Future[Any],
        call: Call,
        timeout: float | None,
        missing: str,
        late: str,
    ) -> None:
        self.result = result
        self.call = call
        self.timeout = timeout
        self.deadline = None if timeout is None else time.monotonic() + timeout
        self.missing = missing
        self.late = late


class _Watched:
    """A call the watchdog times; ``result`` becomes None once it is answered, so the heap
    entry keeps neither the future nor its value until the deadline."""

    __slots__ = ("late", "result")

    def __init__(self, result: concurrent.futures.Future[Any], late: str) -> None:
        self.result: concurrent.futures.Future[Any] | None = result
        self.late = late


class PendingCalls:
    """The open ``block=False`` calls of one client agent."""

    def __init__(
        self,
        host: AgentHost,
        *,
        agent_name: str,
        during: str,
        server_ready: Callable[[], bool],
        failed: Callable[[str], Any],
    ) -> None:
        self._host = host
        self._agent_name = agent_name
        self._during = during  # "call" or "goal": the failure texts say which
        self._server_ready = server_ready
        self._failed = failed
        self._lock = threading.Lock()
        self._open: set[concurrent.futures.Future[Any]] = set()
        self._waiting: list[_Waiting] = []  # the calls whose server is not ready yet
        self._waiter: threading.Thread | None = None
        # (deadline, tie-breaker, call): the answers the watchdog waits for, answered or not;
        # ``_unanswered`` counts those not answered, to compact the heap when most are.
        self._deadlines: list[tuple[float, int, _Watched]] = []
        self._unanswered = 0
        self._order = itertools.count()
        self._wake = threading.Condition(self._lock)
        self._watchdog: threading.Thread | None = None
        self._late: weakref.WeakSet[concurrent.futures.Future[Any]] = weakref.WeakSet()

    def start(
        self,
        result: concurrent.futures.Future[Any],
        call: Call,
        *,
        timeout: float | None,
        missing: str,
        late: str,
    ) -> None:
        """Run ``call(result)`` once the server is ready; ``missing`` (within ``timeout`` s)
        is the failure when it never is, ``late`` when the answer takes longer than ``timeout``
        once the call is made."""
        if self._host.shutdown_event.is_set():
            settle(
                result,
                lambda: self._failed(f"node {self._host.qualified_name!r} is shut down"),
            )
            return
        with self._lock:
            self._open.add(result)
        result.add_done_callback(self._forget)
        self._host.ensure_spinning()
        with self._lock:
            # Calls still held by the waiter go first: a call made as the server appears
            # must not overtake the ones made before it (requests reach it in send() order).
            queued = bool(self._waiting) or self._waiter is not None
        if not queued and self._ready():
            self._call(call, result, timeout, late)
            return
        with self._lock:
            self._waiting.append(_Waiting(result, call, timeout, missing, late))
            if self._waiter is None:
                self._waiter = threading.Thread(
                    target=self._call_when_ready,
                    name=f"pyconnect-{self._agent_name}-wait",
                    daemon=True,
                )
                self._waiter.start()

    def is_late(self, result: concurrent.futures.Future[Any]) -> bool:
        """Whether ``result`` was answered as late (its request should be dropped)."""
        return result in self._late

    def fail_all(self) -> None:
        """Answer every open call as failed: the node shuts down."""
        with self._lock:
            still_open = list(self._open)
        text = self._shut_down_text()
        for result in still_open:
            settle(result, lambda: self._failed(text))

    def fail_waiting(self, text: str) -> int:
        """Answer the calls not made yet (their server not seen) as failed with ``text``: they
        will never be made (the waiter drops answered calls); how many."""
        with self._lock:
            waiting = [w.result for w in self._waiting if not w.result.done()]
        for result in waiting:
            settle(result, functools.partial(self._failed, text))
        return len(waiting)

    def _shut_down_text(self) -> str:
        return f"node {self._host.qualified_name!r} shut down during the {self._during}"

    def _ready(self) -> bool:
        try:
            return self._server_ready()
        except Exception:  # the node was destroyed under the question (shutdown racing)
            return False

    def _call_when_ready(self) -> None:
        """Make the waiting calls once the server is ready, fail those whose timeout runs out
        first; ends when no call waits (restarted by ``start``)."""
        stop = self._host.shutdown_event
        while True:
            shut_down = stop.is_set()  # then the node may be destroyed: ask it nothing
            ready = not shut_down and self._ready()
            now = time.monotonic()
            due: list[_Waiting] = []
            with self._lock:
                calls, self._waiting = self._waiting, []
                for waiting in calls:
                    if waiting.result.done():  # cancelled by its caller, or answered by fail_all
                        continue
                    expired = waiting.deadline is not None and waiting.deadline <= now
                    (due if shut_down or ready or expired else self._waiting).append(waiting)
                remaining = [w.deadline - now for w in self._waiting if w.deadline is not None]
                last = not self._waiting
            for waiting in due:
                if shut_down:
                    text = self._shut_down_text()
                elif ready:
                    self._call(waiting.call, waiting.result, waiting.timeout, waiting.late)
                    continue
                else:
                    text = f"{waiting.missing} within {waiting.timeout} s"
                settle(waiting.result, functools.partial(self._failed, text))
            if last:
                with self._lock:
                    if not self._waiting:  # else calls queued while these were sent: again
                        self._waiter = None
                        return
                continue
            if not ready:
                stop.wait(min([POLL, *remaining]))

    def _call(
        self,
        call: Call,
        result: concurrent.futures.Future[Any],
        timeout: float | None,
        late: str,
    ) -> None:
        if timeout is not None:
            self._watch(result, time.monotonic() + timeout, late)
        try:
            call(result)
        except Exception as error:
            if self._host.shutdown_event.is_set():  # the node was destroyed under the call
                text = self._shut_down_text()
                settle(result, lambda: self._failed(text))
            else:
                with contextlib.suppress(concurrent.futures.InvalidStateError):
                    result.set_exception(error)

    def _forget(self, result: concurrent.futures.Future[Any]) -> None:
        with self._lock:
            self._open.discard(result)

    # -- the watchdog ----------------------------------------------------------------------------
    def _watch(self, result: concurrent.futures.Future[Any], deadline: float, late: str) -> None:
        watched = _Watched(result, late)
        with self._wake:
            heapq.heappush(self._deadlines, (deadline, next(self._order), watched))
            self._unanswered += 1
            if self._watchdog is None:
                self._watchdog = threading.Thread(
                    target=self._watch_deadlines,
                    name=f"pyconnect-{self._agent_name}-deadlines",
                    daemon=True,
                )
                self._watchdog.start()
            elif self._deadlines[0][2] is watched:  # sooner than what the watchdog sleeps on
                self._wake.notify()
        # Outside the lock: a future done already calls back at once, on this thread.
        result.add_done_callback(lambda _result: self._answered(watched))

    def _answered(self, watched: _Watched) -> None:
        """Let an answered call go; the heap sheds such entries once they are most of it."""
        with self._wake:
            if watched.result is None:  # answered as late by the watchdog, which let it go
                return
            watched.result = None
            self._unanswered -= 1
            if self._unanswered == 0:
                self._deadlines.clear()
                self._wake.notify()  # nothing to wait for: the watchdog ends now
            elif len(self._deadlines) > 2 * self._unanswered:
                self._deadlines = [
                    entry for entry in self._deadlines if entry[2].result is not None
                ]
                heapq.heapify(self._deadlines)

    def _watch_deadlines(self) -> None:
        """Answer calls whose answer is late; ends when no call waits (restarted by _watch)."""
        try:
            self._answer_late_calls()
        finally:
            # Should it die of an error, the next _watch starts another: a watchdog left set
            # for a dead thread let every later call's timeout go unheeded.
            with self._wake:
                if self._watchdog is threading.current_thread():
                    self._watchdog = None

    def _answer_late_calls(self) -> None:
        while True:
            with self._wake:
                if not self._deadlines:
                    # Let go under the lock that found nothing to watch: a call watched from
                    # now on starts a new watchdog, none is left to this one, about to end.
                    self._watchdog = None
                    return
                deadline, _order, watched = self._deadlines[0]
                result = watched.result
                if result is None:  # answered in time
                    heapq.heappop(self._deadlines)
                    continue
                remaining = deadline - time.monotonic()
                if remaining > 0:
                    self._wake.wait(min(remaining, LONGEST_SLEEP))
                    continue
                heapq.heappop(self._deadlines)
                watched.result = None
                self._unanswered -= 1
                self._late.add(result)
            settle(result, functools.partial(self._failed, watched.late))
