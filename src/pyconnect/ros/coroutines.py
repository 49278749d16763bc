"""Running ``async def`` handlers: on an asyncio loop per node (or the user's), in order per agent.

rclpy calls callbacks on executor threads, where no asyncio loop runs; a coroutine handler
called there would never be awaited. ``CoroutineRunner`` hands coroutines to a loop instead:
the user's own loop when ``CustomNode(loop=...)`` names one (e.g. a FastAPI app's), else a loop
pyconnect starts on first use in a daemon thread and stops at shutdown.

Each agent gets a ``CoroutineLane``: its coroutines run one after another in arrival order
(as an agent's plain callbacks do), while different agents' coroutines interleave on the loop.
Submitting costs a lock and a deque append; the loop is woken only when the lane was idle, so a
burst of messages costs one wake-up. A cross-thread wake-up costs about as much as handling a
small message, so a lane under a steady stream does not go idle after its queue empties but
looks again ``LINGER_SECONDS`` later (one timer wake-up then serves several messages; an
``async`` handler may start up to that much later). A lane holds at most ``LANE_LIMIT`` waiting
coroutines; a submit beyond that waits (back-pressure, like a slow plain callback) instead of
dropping.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import inspect
import threading
import weakref
from collections import deque
from collections.abc import Awaitable, Callable
from typing import Any

LANE_LIMIT = 100
"""Coroutines an agent may have waiting before a submit blocks."""

LINGER_SECONDS = 0.001
"""How long a lane under a steady stream waits for the next call before it sleeps."""

BUSY_GAP_SECONDS = 0.002
"""A lane woken again within this time counts as under a steady stream."""

ErrorHandler = Callable[[BaseException], None]
DoneHandler = Callable[[Any], None]
_Call = tuple[Callable[..., Any], tuple[Any, ...], DoneHandler | None, ErrorHandler]


def is_async_callable(function: object) -> bool:
    """True for ``async def`` functions and methods, their partials, and ``async __call__``."""
    if inspect.iscoroutinefunction(function):
        return True
    call = getattr(function, "__call__", None)  # noqa: B004 - the method itself is inspected
    return call is not None and inspect.iscoroutinefunction(call)


class CoroutineRunner:
    """Runs coroutines on ``loop`` (the user's), or on a loop of its own started on first use."""

    def __init__(self, loop: asyncio.AbstractEventLoop | None = None, *, name: str) -> None:
        self._given_loop = loop
        self._own_loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()
        self._name = name
        self._stopped = False
        # What stop() cancels: on the user's loop nothing else would (the loop outlives us).
        self._submitted: set[concurrent.futures.Future[Any]] = set()
        self._lanes: weakref.WeakSet[CoroutineLane] = weakref.WeakSet()

    @property
    def loop(self) -> asyncio.AbstractEventLoop:
        """The loop coroutines run on (pyconnect's own one is started here when needed)."""
        if self._given_loop is not None:
            return self._given_loop
        with self._lock:
            if self._own_loop is None:
                if self._stopped:
                    raise RuntimeError(f"{self._name}: the coroutine loop is stopped")
                loop = asyncio.new_event_loop()
                started = threading.Event()
                self._thread = threading.Thread(
                    target=_run_loop, args=(loop, started), name=self._name, daemon=True
                )
                self._thread.start()
                started.wait()
                self._own_loop = loop
            return self._own_loop

    def submit(self, awaitable: Awaitable[Any]) -> concurrent.futures.Future[Any]:
        """Run ``awaitable`` on the loop; a future of its result for any thread to wait on
        (cancelled by ``stop()``; already cancelled once stopped)."""
        future: concurrent.futures.Future[Any]
        with self._lock:
            if self._stopped:
                if inspect.iscoroutine(awaitable):
                    awaitable.close()  # never awaited, and no warning saying so
                future = concurrent.futures.Future()
                future.cancel()
                return future
        future = asyncio.run_coroutine_threadsafe(_awaited(awaitable), self.loop)
        with self._lock:
            self._submitted.add(future)
        future.add_done_callback(self._forget)
        return future

    def _forget(self, future: concurrent.futures.Future[Any]) -> None:
        with self._lock:
            self._submitted.discard(future)

    def lane(self) -> CoroutineLane:
        """An ordered lane for one agent."""
        lane = CoroutineLane(self)
        with self._lock:
            self._lanes.add(lane)
        return lane

    def on_own_loop_thread(self) -> bool:
        """Whether this is the thread of pyconnect's own loop (never the user's loop)."""
        return self._thread is not None and threading.current_thread() is self._thread

    @property
    def stopped(self) -> bool:
        """True once ``stop()`` was called."""
        return self._stopped

    def stop(self, timeout: float | None = 5.0) -> None:
        """Cancel what still runs, on either loop, and end pyconnect's own loop (idempotent).

        A waiting future is cancelled here, at once: a callback waiting for it is released even
        when ``stop()`` runs on the user's loop thread, which cannot run the cancellation until
        ``stop()`` returns. The coroutines themselves are cancelled on their loop.
        """
        with self._lock:
            self._stopped = True
            loop, thread = self._own_loop, self._thread
            submitted, lanes = list(self._submitted), list(self._lanes)
        for future in submitted:
            future.cancel()  # asyncio cancels the coroutine's task on its loop
        for lane in lanes:
            lane.cancel()
        if loop is None or thread is None:
            return
        with contextlib.suppress(RuntimeError):  # already closed
            loop.call_soon_threadsafe(loop.stop)
        # On the loop's own thread (a handler stopping it) the loop ends once this returns.
        if thread is not threading.current_thread():
            thread.join(timeout)


class CoroutineLane:
    """One agent's coroutines, awaited one after another in the order they were submitted.

    One task per lane lives on the loop: it awaits the queued calls, then sleeps on a future
    that the next submit resolves (one cross-thread wake-up per burst, no task per message).
    """

    def __init__(self, runner: CoroutineRunner) -> None:
        self._runner = runner
        self._pending: deque[_Call] = deque()
        self._cond = threading.Condition()
        self._draining = False
        self._task: asyncio.Future[Any] | None = None
        self._idle: asyncio.Future[None] | None = None

    def submit(
        self,
        function: Callable[..., Any],
        args: tuple[Any, ...],
        *,
        on_done: DoneHandler | None,
        on_error: ErrorHandler,
    ) -> None:
        """Queue ``function(*args)`` (a coroutine function): then ``on_done(result)``, or
        ``on_error(exception)`` when it raised. Dropped once the runner is stopped (shutdown)."""
        with self._cond:
            if self._runner.stopped:
                return
            while len(self._pending) >= LANE_LIMIT and not self._runner.stopped:
                self._cond.wait(0.1)
            self._pending.append((function, args, on_done, on_error))
            if self._draining:
                return
            self._draining = True
        try:
            self._runner.loop.call_soon_threadsafe(self._wake)
        except RuntimeError:  # the loop closed under us: shutdown is under way
            with self._cond:
                self._pending.clear()
                self._draining = False

    def cancel(self) -> None:
        """Cancel the lane's task on its loop (the runner stops; callable from any thread)."""
        task = self._task
        if task is not None and not task.done():
            with contextlib.suppress(RuntimeError):  # the loop is closed: nothing runs
                task.get_loop().call_soon_threadsafe(task.cancel)

    def _wake(self) -> None:
        """On the loop: start the lane's task, or wake it from its idle wait."""
        if self._runner.stopped:  # queued before shutdown, run after it: nothing is handed on
            with self._cond:
                self._pending.clear()
                self._draining = False
            return
        if self._task is None or self._task.done():
            self._task = asyncio.ensure_future(self._drain())
            _keep_alive.add(self._task)
            self._task.add_done_callback(_keep_alive.discard)
        elif self._idle is not None and not self._idle.done():
            self._idle.set_result(None)

    async def _drain(self) -> None:
        loop = asyncio.get_running_loop()
        busy = False
        while True:
            if busy and not self._pending:
                # Under a steady stream, look again a moment later instead of making the next
                # submit wake the loop: one wake-up then serves several calls.
                await asyncio.sleep(LINGER_SECONDS)
                busy = bool(self._pending)
            with self._cond:
                if self._runner.stopped:  # shutdown: what waits is not handed on
                    self._pending.clear()
                    self._draining = False
                    return
                if not self._pending:
                    self._draining = False
                    self._idle = loop.create_future()
                    idle = self._idle
                else:
                    idle = None
                    function, args, on_done, on_error = self._pending.popleft()
                    if len(self._pending) == LANE_LIMIT - 1:
                        self._cond.notify()
            if idle is not None:
                slept = loop.time()
                await idle
                busy = loop.time() - slept < BUSY_GAP_SECONDS
                continue
            try:
                result = await function(*args)
            except asyncio.CancelledError as error:
                if self._runner.stopped or _being_cancelled():
                    raise  # the lane's own task: shutdown
                on_error(error)  # the handler's own (an awaited thing was cancelled): go on
                continue
            except Exception as error:
                on_error(error)
                continue
            if on_done is not None:
                on_done(result)


def _being_cancelled() -> bool:
    """Whether the running task itself was asked to stop (``Task.cancelling``, Python 3.11+)."""
    task = asyncio.current_task()
    cancelling = getattr(task, "cancelling", None)
    return bool(cancelling()) if cancelling is not None else False


# Tasks are only weakly referenced by asyncio; these keep running lanes alive.
_keep_alive: set[asyncio.Future[Any]] = set()


async def _awaited(awaitable: Awaitable[Any]) -> Any:
    return await awaitable


def _run_loop(loop: asyncio.AbstractEventLoop, started: threading.Event) -> None:
    asyncio.set_event_loop(loop)
    loop.call_soon(started.set)
    try:
        loop.run_forever()
        # Let cancelled handlers run their ``finally`` blocks before the loop closes.
        tasks = asyncio.all_tasks(loop)
        for task in tasks:
            task.cancel()
        loop.run_until_complete(asyncio.gather(*tasks, return_exceptions=True))
        loop.run_until_complete(loop.shutdown_asyncgens())
    finally:
        loop.close()
