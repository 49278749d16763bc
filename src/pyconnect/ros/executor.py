"""The elastic executor: callbacks run inline on one thread that hands spinning on if one blocks.

Why not the stock executors (docs/ros-facts.md): ``MultiThreadedExecutor`` hands every callback to a
pool (3.5x slower than single-threaded, tails of tens of ms); ``SingleThreadedExecutor`` is fast
but a callback that blocks (a ``response_func`` calling another agent's blocking ``send()``, a
long image computation, an action running for seconds) stops every other agent, and a blocking
service call inside a callback deadlocks (rclpy#1398, #1313). ``EventsExecutor`` runs its loop
in C++, so a callback cannot hand the loop to another thread.

This executor keeps the single-threaded fast path and adds one idea, the *turn*: exactly one
thread at a time (the owner) waits for work and runs the callback it got, inline. When the
owner's callback blocks (``wait_for`` called from it, i.e. a blocking ``send()``) or runs longer
than ``handoff_after`` seconds (seen by a monitor thread: it looks ``handoff_after`` after a
callback starts, every ``BUSY_LOOK`` while callbacks keep coming, and parks while none comes,
woken by the next callback to start; so after 20-120 ms), the turn passes to a standby thread,
started on demand, which keeps spinning while the old owner finishes its callback and then
becomes a standby itself. Callback groups keep their rclpy meaning: the
agents put each of their entities in their own mutually exclusive group, so one agent's
callbacks never overlap (messages stay in order) while different agents run side by side when
one of them is slow. On the fast path the cost over ``SingleThreadedExecutor`` is two
uncontended lock round trips and a few attribute stores per callback.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import contextlib
import heapq
import threading
import time
from collections.abc import Callable
from typing import Any

from rclpy.context import Context
from rclpy.executors import (
    ConditionReachedException,
    Executor,
    ExternalShutdownException,
    ShutdownException,
    TimeoutException,
    TimeoutObject,
)
from rclpy.task import Future

from pyconnect.ros.wait_plan import COOL_AFTER, PlannedWaits, WakeGuard
from pyconnect.ros.waiting import EventLike, running_thread

DEFAULT_HANDOFF_AFTER = 0.02
"""Seconds a callback may hold the turn before another thread takes over spinning."""

BUSY_LOOK = 0.1
"""Seconds between the monitor's looks while callbacks come but none ran at the last look."""

_STANDBY_LIMIT = 1
"""Idle helper threads kept beyond the spinning ones; extra helpers end when they go idle."""


class ElasticExecutor(Executor):  # type: ignore[misc]
    """A single-threaded executor that never lets one blocking callback stop the others.

    ``spin()`` loops in the calling thread until ``stop()`` or shutdown; ``wait_for(event)``
    waits for something a callback will do, from any thread, without deadlocking.
    """

    def __init__(
        self,
        *,
        context: Context | None = None,
        handoff_after: float = DEFAULT_HANDOFF_AFTER,
        on_error: Callable[[BaseException], None] | None = None,
        cool_after: float = COOL_AFTER,
    ) -> None:
        super().__init__(context=context)
        self._handoff_after = handoff_after
        self._on_error = on_error
        self._turn = threading.Condition()
        self._owner: int | None = None
        self._busy_since: float | None = None
        self._idle = 0
        self._spinners = 0
        self._stopping = False
        self._helpers: list[threading.Thread] = []
        self._monitor: threading.Thread | None = None
        self._monitor_stop = threading.Event()
        # Callbacks started so far, and whether the monitor is parked until the next one starts.
        self._started = 0
        self._monitor_parked = False
        self._monitor_wake = threading.Event()
        self._waker = _DeadlineWaker(self.wake)
        self._running = 0
        self._last_handoff = time.monotonic()
        self._wake_guard = WakeGuard(self._guard)
        # rclpy triggers this guard from its handlers, wake(), create_task() and shutdown().
        self._guard = self._wake_guard  # type: ignore[assignment]
        self._waits = PlannedWaits(self, cool_after=cool_after)

    # -- public --------------------------------------------------------------------------------
    @property
    def is_spinning(self) -> bool:
        """True while some thread runs ``spin()``."""
        return self._spinners > 0 and not self._stopping

    def is_calm(self, seconds: float) -> bool:
        """True when no callback runs and no hand-off happened for ``seconds``."""
        with self._turn:
            return self._running == 0 and time.monotonic() - self._last_handoff >= seconds

    def wait_counts(self) -> dict[str, int]:
        """Wait sets built, waits on them, cold-waiter wake-ups so far and entities it waits
        on now (pyconnect.ros.wait_plan, cold_waiter)."""
        return {
            "plans": self._waits.plans,
            "waits": self._waits.waits,
            "cold_wakes": self._waits.cold_wakes,
            "cold": self._waits.cold,
        }

    def is_cold(self, entity: Any) -> bool:
        """True if ``entity`` went quiet and waits on the cold waiter's thread now."""
        return self._waits.is_cold(entity)

    def wake(self) -> None:
        """Make the executor notice new entities (rclpy's nodes call this on every change)."""
        self._waits.may_have_changed()
        super().wake()

    def add_node(self, node: Any) -> bool:
        self._waits.may_have_changed()
        added: bool = super().add_node(node)
        return added

    def remove_node(self, node: Any) -> None:
        self._waits.may_have_changed()
        super().remove_node(node)

    def spin(self) -> None:
        """Run callbacks in this thread (and helpers, when one blocks) until ``stop()``."""
        with self._turn:
            self._spinners += 1
        self._start_monitor()
        try:
            while not self._stopping and self._take_turn(helper=False):
                pass
        finally:
            with self._turn:
                self._spinners -= 1

    def spin_once(self, timeout_sec: float | None = None) -> None:
        """Run at most one callback in this thread (rclpy's executor API)."""
        self._take_turn(helper=False, timeout_sec=timeout_sec)

    def spin_until_future_complete(self, future: Future, timeout_sec: float | None = None) -> None:
        """Spin, or wait for the spinning thread, until ``future`` is done (rclpy's API)."""
        done = threading.Event()
        future.add_done_callback(lambda _future: done.set())
        if future.done():
            return
        self.wait_for(done, timeout_sec, poll=future.done)

    def wait_for(
        self,
        event: EventLike,
        timeout_sec: float | None,
        *,
        poll: Callable[[], bool] | None = None,
    ) -> bool:
        """Wait until ``event`` is set by a callback; True if it was, False on timeout.

        When a ``spin()`` runs, this thread only waits; if this thread holds the turn (we are
        inside a callback) it passes the turn first, so the callback that sets ``event`` can
        run. When nothing spins, this thread spins until ``event`` is set.
        """
        finished = poll if poll is not None else event.is_set
        deadline = None if timeout_sec is None else time.monotonic() + timeout_sec
        me = threading.get_ident()
        waker_set = False
        while not event.is_set() and not finished():
            remaining = None if deadline is None else deadline - time.monotonic()
            if remaining is not None and remaining <= 0:
                return False
            if self.is_spinning or self._owner == me:
                # Inside a callback, or a spin() runs elsewhere: pass the turn and just wait.
                if self._owner == me:
                    self._hand_off(me)
                # Wake up now and then only to notice that the spinning thread went away.
                event.wait(0.25 if remaining is None else min(remaining, 0.25))
            elif self._stopping or self._is_shutdown:
                return event.is_set() or finished()
            else:
                # No timeout for rclpy: it would build an rcl timer per wait (a third of a
                # round trip). The deadline waker triggers the executor's guard instead.
                if deadline is not None and not waker_set:
                    self._waker.wake_at(deadline)
                    waker_set = True
                self._take_turn(
                    helper=False,
                    condition=lambda: (
                        finished() or (deadline is not None and time.monotonic() >= deadline)
                    ),
                )
        return True

    def release_turn(self) -> None:
        """Pass the turn on when this thread holds it (a callback about to wait for another)."""
        me = threading.get_ident()
        if self._owner == me:
            self._hand_off(me)

    def stop(self) -> None:
        """Make every ``spin()`` return; callbacks in progress finish on their own threads."""
        with self._turn:
            self._stopping = True
            self._turn.notify_all()
        self._monitor_stop.set()
        self._monitor_wake.set()
        self._waker.stop()
        # The guard condition may already be destroyed.
        with contextlib.suppress(Exception):
            self.wake()

    def join(self, timeout_sec: float | None = None) -> None:
        """Wait for helper threads and the monitor to end (after ``stop()``)."""
        current = threading.current_thread()
        for thread in [*list(self._helpers), self._monitor, self._waker.thread]:
            if thread is not None and thread is not current and thread.is_alive():
                thread.join(timeout_sec)
        if self._stopping:
            # Lets go of the entities' handles (rclpy destroys what was destroyed meanwhile).
            self._waits.close()
            self._waits.join(timeout_sec)

    def shutdown(self, timeout_sec: float | None = None) -> bool:
        self.stop()
        self.join(timeout_sec)
        result: bool = super().shutdown(timeout_sec)
        return result

    def _wait_for_ready_callbacks(
        self,
        timeout_sec: float | TimeoutObject | None = None,
        nodes: list[Any] | None = None,
        condition: Callable[[], bool] = lambda: False,
    ) -> Any:
        # One wait set kept between wake-ups (pyconnect.ros.wait_plan).
        seconds = timeout_sec.timeout if isinstance(timeout_sec, TimeoutObject) else timeout_sec
        return self._waits.ready_callbacks(seconds, nodes, condition, self._wake_guard)

    # -- the turn ------------------------------------------------------------------------------
    def _stop_requested(self) -> bool:
        return self._stopping

    def _take_turn(
        self,
        *,
        helper: bool,
        timeout_sec: float | None = None,
        condition: Callable[[], bool] | None = None,
    ) -> bool:
        """Wait for the turn, then for one callback, and run it. False when spinning must end."""
        me = threading.get_ident()
        with self._turn:
            while self._owner is not None and not self._stopping:
                if helper and self._idle >= _STANDBY_LIMIT:
                    return False
                if condition is not None and self._spinners > 0:
                    # A spin() started meanwhile: the caller waits for its event instead.
                    return True
                self._idle += 1
                self._turn.wait(None if condition is None else 0.25)
                self._idle -= 1
            if self._stopping:
                return False
            self._owner = me
        try:
            try:
                ready: tuple[Any, Any, Any]
                if condition is None:
                    # Constant arguments let rclpy reuse its generator of ready callbacks.
                    ready = self.wait_for_ready_callbacks(None, None, self._stop_requested)
                else:
                    ready = self.wait_for_ready_callbacks(timeout_sec, None, condition)
                handler = ready[0]
            except (TimeoutException, ConditionReachedException):
                return not self._stopping
            except (ShutdownException, ExternalShutdownException):
                self._stopping = True
                return False
            # Read by the monitor without the lock: a stale value only costs a spare hand-off.
            self._busy_since = time.monotonic()
            self._started += 1
            if self._monitor_parked:  # only the first callback after a quiet spell
                self._monitor_wake.set()
            with self._turn:
                self._running += 1
            try:
                handler()
            finally:
                with self._turn:
                    self._running -= 1
            error = handler.exception()
            if error is not None:
                self._report(error)
            return not self._stopping
        finally:
            with self._turn:
                if self._owner == me:
                    self._owner = None
                    self._busy_since = None
                    self._turn.notify()

    def _hand_off(self, owner: int) -> None:
        """Pass the turn away from ``owner`` if it holds it; start a helper if none is idle."""
        with self._turn:
            if self._owner != owner or self._stopping:
                return
            self._owner = None
            self._busy_since = None
            self._last_handoff = time.monotonic()
            if self._idle == 0:
                helper = threading.Thread(
                    target=self._helper_loop, name="pyconnect-executor-helper", daemon=True
                )
                self._helpers = [thread for thread in self._helpers if thread.is_alive()]
                self._helpers.append(helper)
                helper.start()
            self._turn.notify()

    def runs_on(self, thread: threading.Thread) -> bool:
        """Whether ``thread`` is one of this executor's helper threads."""
        return thread in self._helpers

    def _helper_loop(self) -> None:
        while not self._stopping and self._take_turn(helper=True):
            pass

    def _start_monitor(self) -> None:
        with self._turn:
            self._monitor = running_thread(
                self._monitor, self._monitor_loop, "pyconnect-executor-monitor"
            )

    def _monitor_loop(self) -> None:
        """Hand the turn off when the owner's callback has run for longer than ``handoff_after``."""
        seen, came = self._started, False
        since: float | None = None
        while not self._monitor_stop.is_set():
            if since is not None:
                # A callback ran at the last look: look again once it has run handoff_after.
                self._monitor_wake.wait(max(since + self._handoff_after - time.monotonic(), 1e-3))
            elif came:
                # Callbacks come, none ran at the last look: one that starts now and runs long
                # is seen at the next look (a wake-up per BUSY_LOOK under a steady stream,
                # rather than one per callback).
                self._monitor_wake.wait(max(BUSY_LOOK, self._handoff_after))
            else:
                # Quiet: no wake-ups until a callback starts and wakes us. One that started
                # since the last look did not see the flag: look now.
                self._monitor_parked = True
                if self._started == seen and self._busy_since is None:
                    self._monitor_wake.wait()
                self._monitor_parked = False
            self._monitor_wake.clear()
            if self._monitor_stop.is_set():
                return
            with self._turn:
                owner, since = self._owner, self._busy_since
            started = self._started
            came, seen = started != seen, started
            if (
                owner is not None
                and since is not None
                and time.monotonic() - since >= self._handoff_after
            ):
                self._hand_off(owner)
                since = None

    def _report(self, error: BaseException) -> None:
        if self._on_error is not None:
            self._on_error(error)
        else:
            import traceback

            traceback.print_exception(error)


class _DeadlineWaker:
    """One thread that calls ``wake`` at registered deadlines (started on first use)."""

    def __init__(self, wake: Callable[[], None]) -> None:
        self._wake = wake
        self._deadlines: list[float] = []
        self._cond = threading.Condition()
        self._stopped = False
        self.thread: threading.Thread | None = None

    def wake_at(self, deadline: float) -> None:
        with self._cond:
            if self._stopped:
                return
            heapq.heappush(self._deadlines, deadline)
            if self.thread is None:
                self.thread = threading.Thread(
                    target=self._run, name="pyconnect-executor-waker", daemon=True
                )
                self.thread.start()
            # Waking the thread costs a context switch: only when it must wake up earlier.
            if self._deadlines[0] == deadline:
                self._cond.notify()

    def stop(self) -> None:
        with self._cond:
            self._stopped = True
            self._cond.notify()

    def _run(self) -> None:
        with self._cond:
            while not self._stopped:
                if not self._deadlines:
                    self._cond.wait()
                    continue
                delay = self._deadlines[0] - time.monotonic()
                if delay > 0:
                    self._cond.wait(delay)
                    continue
                heapq.heappop(self._deadlines)
                with contextlib.suppress(Exception):
                    self._wake()
