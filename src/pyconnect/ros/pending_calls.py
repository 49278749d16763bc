"""A client agent's ``block=False`` calls: started when the server is ready, always answered.

Both client kinds (service, action) hand their non-blocking calls to a ``PendingCalls``: the
call starts at once when the server is ready, else on a thread that waits for it (a future
that the caller cancels meanwhile is dropped); the node spins in the background from then on,
since the answer needs callbacks to run, as a blocking ``send()`` and ``wait_until_connected``
start it. ``timeout`` holds as for a blocking call: for the server to appear, then for the
answer (one watchdog thread per agent, alive only while calls wait for answers); a late call
is answered with the failure value and ``is_late`` tells the agent to drop its request or
cancel its goal. A future still open when the node shuts down gets the failed value, so nothing
waits on it for ever; on a node already shut down the future is failed from the start.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import heapq
import itertools
import threading
import time
import weakref
from collections.abc import Callable
from typing import Any

from pyconnect.ros.agent_host import AgentHost
from pyconnect.ros.waiting import settle, wait_until

Call = Callable[[concurrent.futures.Future[Any]], object]
"""Starts the middleware call that will settle the future it is given."""


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
        # (deadline, tie-breaker, future, failure text): the answers the watchdog waits for.
        self._deadlines: list[tuple[float, int, concurrent.futures.Future[Any], str]] = []
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
        if self._ready():
            self._call(call, result, timeout, late)
            return
        threading.Thread(
            target=self._call_when_ready,
            args=(call, result, timeout, missing, late),
            name=f"pyconnect-{self._agent_name}-wait",
            daemon=True,
        ).start()

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

    def _shut_down_text(self) -> str:
        return f"node {self._host.qualified_name!r} shut down during the {self._during}"

    def _ready(self) -> bool:
        try:
            return self._server_ready()
        except Exception:  # the node was destroyed under the question (shutdown racing)
            return False

    def _call_when_ready(
        self,
        call: Call,
        result: concurrent.futures.Future[Any],
        timeout: float | None,
        missing: str,
        late: str,
    ) -> None:
        ready = wait_until(self._ready, timeout, stop=self._host.shutdown_event)
        if result.done():  # cancelled by its caller, or answered by fail_all
            return
        if ready:
            self._call(call, result, timeout, late)
        elif self._host.shutdown_event.is_set():
            text = self._shut_down_text()
            settle(result, lambda: self._failed(text))
        else:
            settle(result, lambda: self._failed(f"{missing} within {timeout} s"))

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
        with self._wake:
            heapq.heappush(self._deadlines, (deadline, next(self._order), result, late))
            if self._watchdog is None:
                self._watchdog = threading.Thread(
                    target=self._watch_deadlines,
                    name=f"pyconnect-{self._agent_name}-deadlines",
                    daemon=True,
                )
                self._watchdog.start()
            elif self._deadlines[0][2] is result:  # sooner than what the watchdog sleeps on
                self._wake.notify()

    def _watch_deadlines(self) -> None:
        """Answer calls whose answer is late; ends when no call waits (restarted by _watch)."""
        while True:
            with self._wake:
                while self._deadlines and self._deadlines[0][2].done():
                    heapq.heappop(self._deadlines)  # answered in time
                if not self._deadlines:
                    self._watchdog = None
                    return
                deadline, _order, result, late = self._deadlines[0]
                remaining = deadline - time.monotonic()
                if remaining > 0:
                    self._wake.wait(remaining)
                    continue
                heapq.heappop(self._deadlines)
                self._late.add(result)
            settle(result, lambda text=late: self._failed(text))  # type: ignore[misc]
