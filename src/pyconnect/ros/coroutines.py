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
dropping, except on the loop's own thread: only that thread drains the lane, so there a submit
never waits and the lane holds more for a while.

Nothing a coroutine raises ends the loop: a ``SystemExit`` or ``KeyboardInterrupt`` (a handler's
``sys.exit()``) goes to the lane's ``on_error`` like any error, then to its ``on_exit`` (the
agent shuts its node down, as for a plain handler), and ``submit`` hands it to its waiter
wrapped in ``CoroutineExit``. A loop given to ``CustomNode(loop=)`` that is closed, or not
running, when a coroutine is submitted cannot run it: ``submit`` fails its future with
``LOOP_CLOSED``/``LOOP_NOT_RUNNING`` (and closes the coroutine: a service or action caller is
answered at once). A lane reports a closed loop once to ``on_error`` and drops its calls; calls
for a loop not running yet wait for it, up to ``LANE_LIMIT``, beyond which they are dropped
and that is reported (a loop started after the node is made loses nothing).
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

from pyconnect.errors import PyconnectError

LANE_LIMIT = 100
"""Coroutines an agent may have waiting before a submit blocks."""

LINGER_SECONDS = 0.001
"""How long a lane under a steady stream waits for the next call before it sleeps."""

BUSY_GAP_SECONDS = 0.002
"""A lane woken again within this time counts as under a steady stream."""

LOOP_CLOSED = "the asyncio loop given to CustomNode(loop=) is closed"
"""Why a coroutine cannot run: the user's loop ended before the node."""

LOOP_NOT_RUNNING = "the asyncio loop given to CustomNode(loop=) is not running"
"""Why a coroutine cannot run: the user's loop was stopped (or not started yet)."""

ErrorHandler = Callable[[BaseException], None]
DoneHandler = Callable[[Any], None]
_Call = tuple[Callable[..., Any], tuple[Any, ...], DoneHandler | None, ErrorHandler]


class CoroutineExit(Exception):
    """A coroutine raised ``SystemExit`` or ``KeyboardInterrupt`` (``error``): carried to whoever
    waits for it, because raised on the loop it would end the loop (asyncio lets both out of
    ``run_forever``)."""

    def __init__(self, error: BaseException) -> None:
        super().__init__(f"{type(error).__name__}: {error}")
        self.error = error


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
        (cancelled by ``stop()``; already cancelled once stopped; failed with a
        ``PyconnectError`` when the given loop is closed or not running)."""
        future: concurrent.futures.Future[Any]
        with self._lock:
            if self._stopped:
                _close(awaitable)  # never awaited, and no warning saying so
                future = concurrent.futures.Future()
                future.cancel()
                return future
        problem = self.loop_problem()
        if problem is None:
            wrapper = _awaited(awaitable)
            try:
                future = asyncio.run_coroutine_threadsafe(wrapper, self.loop)
            except RuntimeError:  # closed since loop_problem() looked
                wrapper.close()
                problem = LOOP_CLOSED
        if problem is not None:
            _close(awaitable)
            future = concurrent.futures.Future()
            future.set_exception(PyconnectError(problem))
            return future
        with self._lock:
            self._submitted.add(future)
        future.add_done_callback(self._forget)
        return future

    def _forget(self, future: concurrent.futures.Future[Any]) -> None:
        with self._lock:
            self._submitted.discard(future)

    def lane(self, *, on_exit: ErrorHandler | None = None) -> CoroutineLane:
        """An ordered lane for one agent; ``on_exit(error)`` follows ``on_error`` when a call
        raised ``SystemExit`` or ``KeyboardInterrupt`` (a handler's ``sys.exit()``)."""
        lane = CoroutineLane(self, on_exit=on_exit)
        with self._lock:
            self._lanes.add(lane)
        return lane

    def on_own_loop_thread(self) -> bool:
        """Whether this is the thread of pyconnect's own loop (never the user's loop)."""
        return self._thread is not None and threading.current_thread() is self._thread

    def on_loop_thread(self) -> bool:
        """Whether this thread runs the coroutine loop, pyconnect's own or the given one: a wait
        here for something a coroutine does would never end (only this thread runs them)."""
        if self.on_own_loop_thread():
            return True
        given = self._given_loop
        if given is None:
            return False
        try:
            return asyncio.get_running_loop() is given
        except RuntimeError:  # no loop runs in this thread (an executor's)
            return False

    def loop_problem(self) -> str | None:
        """Why the given loop cannot run a coroutine now (``LOOP_CLOSED``, ``LOOP_NOT_RUNNING``);
        None when it can, for pyconnect's own loop, and once stopped (shutdown drops calls)."""
        loop = self._given_loop
        if loop is None or self._stopped:
            return None
        if loop.is_closed():
            return LOOP_CLOSED
        if not loop.is_running():
            return LOOP_NOT_RUNNING
        return None

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

    def __init__(self, runner: CoroutineRunner, *, on_exit: ErrorHandler | None = None) -> None:
        self._runner = runner
        self._on_exit = on_exit
        self._pending: deque[_Call] = deque()
        self._cond = threading.Condition()
        self._draining = False
        self._task: asyncio.Future[Any] | None = None
        self._idle: asyncio.Future[None] | None = None
        self._refused: str | None = None  # the loop problem reported last (reported once)

    def submit(
        self,
        function: Callable[..., Any],
        args: tuple[Any, ...],
        *,
        on_done: DoneHandler | None,
        on_error: ErrorHandler,
    ) -> None:
        """Queue ``function(*args)`` (a coroutine function): then ``on_done(result)``, or
        ``on_error(exception)`` when it raised (``SystemExit`` included). Dropped once the runner
        is stopped (shutdown), while the given loop is closed, and beyond ``LANE_LIMIT`` while it
        is not running (reported once to ``on_error``).

        Beyond ``LANE_LIMIT`` waiting calls, a submit waits for the lane to drain, except on the
        loop's own thread (a coroutine's call, a callback of the loop): that thread is the one
        that drains the lane, so it never waits here; the call is queued beyond the limit.
        """
        runner = self._runner
        # Per message: the checks that need more than an attribute read run only when they can
        # matter (a loop given to the node; a full lane).
        if runner._given_loop is not None and runner.loop_problem() == LOOP_CLOSED:
            self._refuse(LOOP_CLOSED, on_error)
            return
        stuck = False
        with self._cond:
            if runner.stopped:
                return
            while (
                len(self._pending) >= LANE_LIMIT
                and not runner.stopped
                and not runner.on_loop_thread()
            ):
                if self._runner.loop_problem() is not None:
                    # A loop that does not run never drains the lane: waiting would hold the
                    # executor's thread for ever. (Below the limit, calls wait for it to start.)
                    stuck = True
                    break
                self._cond.wait(0.1)
            if not stuck:
                self._refused = None
                self._pending.append((function, args, on_done, on_error))
                if self._draining:
                    return
                self._draining = True
        if stuck:
            self._refuse(self._runner.loop_problem() or LOOP_NOT_RUNNING, on_error)
            return
        try:
            self._runner.loop.call_soon_threadsafe(self._wake)
        except RuntimeError:  # the loop closed under us
            with self._cond:
                self._pending.clear()
                self._draining = False
            if not self._runner.stopped:  # the user's loop ended before the node: say so
                self._refuse(LOOP_CLOSED, on_error)

    def _refuse(self, problem: str, on_error: ErrorHandler) -> None:
        """Report once that the loop cannot run this lane's calls (until one runs again)."""
        with self._cond:
            if self._refused == problem:
                return
            self._refused = problem
        on_error(PyconnectError(problem))

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
                _hand_on(on_error, error)  # the handler's own (an awaited thing was cancelled)
                continue
            except BaseException as error:  # SystemExit too: let out, it would end the loop
                _hand_on(on_error, error)
                if self._on_exit is not None and isinstance(error, (SystemExit, KeyboardInterrupt)):
                    _hand_on(self._on_exit, error)
                continue
            if on_done is not None:
                try:  # inline: this runs per message (_hand_on's call, for errors only)
                    on_done(result)
                except Exception as error:
                    loop.call_exception_handler(
                        {"message": "a coroutine lane's result handler raised", "exception": error}
                    )


def _hand_on(handler: Callable[[Any], None], value: Any) -> None:
    """Call a lane's ``on_done``/``on_error``; what it raises goes to the loop's exception
    handler, so the lane goes on (a lane task that died would never drain again)."""
    try:
        handler(value)
    except Exception as error:
        asyncio.get_running_loop().call_exception_handler(
            {"message": "a coroutine lane's result handler raised", "exception": error}
        )


def _being_cancelled() -> bool:
    """Whether the running task itself was asked to stop (``Task.cancelling``, Python 3.11+)."""
    task = asyncio.current_task()
    cancelling = getattr(task, "cancelling", None)
    return bool(cancelling()) if cancelling is not None else False


# Tasks are only weakly referenced by asyncio; these keep running lanes alive.
_keep_alive: set[asyncio.Future[Any]] = set()


async def _awaited(awaitable: Awaitable[Any]) -> Any:
    try:
        return await awaitable
    except (SystemExit, KeyboardInterrupt) as error:
        raise CoroutineExit(error) from error  # for the waiter: raised, it would end the loop


def _close(awaitable: Awaitable[Any]) -> None:
    """Close a coroutine that will never be awaited (else Python warns it never was)."""
    if inspect.iscoroutine(awaitable):
        awaitable.close()


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
