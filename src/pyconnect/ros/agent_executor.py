"""The agents' executor: rclpy's C++ ``EventsExecutor`` while callbacks are quick, elastic when not.

Why: the cost of a Python wait-set executor (``SingleThreadedExecutor``, and the
``ElasticExecutor`` built on it) is 2-3x that of ``rclpy.experimental.EventsExecutor`` for a
timer or a subscription at 100 Hz-1 kHz (bench/agents.py). But ``EventsExecutor`` runs every
callback inline under one C++ mutex: a callback that blocks (a ``response_func`` calling a
blocking ``send()``, rclpy#1398) deadlocks it, and a slow one stops every other agent.

So the node lives on an ``EventsExecutor`` (driven by ``spin_once(timeout_sec=...)``: its
``spin()`` busy-loops and never fires timers in the 7.1.6 wheel) and callbacks run inline on the
one dispatching thread. When a callback blocks — it calls ``wait_for`` (a blocking ``send()``), or
a monitor sees it still running after ``handoff_after`` seconds — the node moves, while that
callback goes on, to a fresh ``ElasticExecutor`` (pyconnect.ros.executor) spinning on another
thread: the blocked callback gets its response and the other agents keep running. The callback
group of the callback that was running stays held until it returns, so an agent never runs two
of its callbacks at once. Once the elastic executor has been calm for ``CALM_AFTER`` seconds (no
callback running, no hand-off), the node moves back to a new ``EventsExecutor``.

The watch over running callbacks (wrappers and a monitor thread) is
pyconnect.ros.callback_watch: a slow callback is noticed after 20-120 ms; a blocking ``send()``
at once. The moves themselves are pyconnect.ros.executor_moves.

A callback that raises never kills the executor, not even with what is no ``Exception``: a
``SystemExit`` or ``KeyboardInterrupt`` (a handler's ``sys.exit()``: "the task is done, end the
program") is reported and shuts the nodes down, so a blocking ``spin()`` returns and the program
ends normally; any other ``BaseException`` is reported and the executor goes on.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Callable
from typing import Any

from rclpy.context import Context
from rclpy.executors import ExternalShutdownException, ShutdownException
from rclpy.node import Node
from rclpy.task import Future

from pyconnect.ros.callback_watch import IDLE_TICK
from pyconnect.ros.executor import DEFAULT_HANDOFF_AFTER, ElasticExecutor
from pyconnect.ros.executor_moves import ExecutorMoves
from pyconnect.ros.waiting import EventLike


class AgentExecutor(ExecutorMoves):
    """Runs one node's callbacks: inline on ``EventsExecutor``, elastic when one blocks.

    The API is the part of rclpy's ``Executor`` that ``CustomNode`` and the agents use, plus
    ``wait_for(event)``: wait, from any thread, for something a callback will do.
    """

    def __init__(
        self,
        *,
        context: Context,
        handoff_after: float = DEFAULT_HANDOFF_AFTER,
        on_error: Callable[[BaseException], None] | None = None,
    ) -> None:
        self.context = context
        self._handoff_after = handoff_after
        self._on_error = on_error
        self._nodes: list[Node] = []
        self._lock = threading.Lock()
        self._events: Any = self._new_events()
        self._elastic: ElasticExecutor | None = None
        self._elastic_thread: threading.Thread | None = None
        self._retired: list[Any] = []
        self._stopping = False
        self._stopped = threading.Event()
        self._dispatcher: int | None = None
        # The EventsExecutor a dispatcher is inside spin_once of, and whether stop() made its
        # wake-up task; under a lock of their own: ``_lock`` may be held a while (_go_elastic).
        self._spin_lock = threading.Lock()
        self._spun: Any = None
        self._woken = False
        self._spinning = False
        self._background: threading.Thread | None = None
        # What the wrapped callback on the dispatching thread is doing (read by the monitor).
        self._seq = 0
        self._running: tuple[Any, Any] | None = None
        self._held: tuple[Any, Any] | None = None
        self._returns = 0
        self._monitor: threading.Thread | None = None
        self._monitor_wake = threading.Event()
        self._monitor_parked = False
        self.handoffs = 0
        """How many times the node moved to the elastic executor (tests and diagnostics)."""

    # -- nodes ---------------------------------------------------------------------------------
    def add_node(self, node: Node) -> bool:
        with self._lock:
            if node in self._nodes:
                return False
            self._nodes.append(node)
            target = self._elastic if self._elastic is not None else self._events
        node.executor = target
        self._watch(node)
        self.adopt(node)
        return True

    def remove_node(self, node: Node) -> None:
        with self._lock:
            if node not in self._nodes:
                return
            self._nodes.remove(node)
            target = self._elastic if self._elastic is not None else self._events
        self._unwatch(node)
        target.remove_node(node)
        if target is self._events and not self._spinning:
            # Unregisters the entities' listeners now, while they still exist.
            with contextlib.suppress(Exception):
                self._events.shutdown(timeout_sec=1.0)
            self._events = self._new_events()
            for other in self._nodes:
                other.executor = self._events

    def get_nodes(self) -> list[Node]:
        return list(self._nodes)

    def adopt(self, node: Node | None = None) -> None:
        """Wrap the callbacks of entities created since the last call (cheap; call after adding).

        The wrapper tells the monitor which callback runs and since when
        (pyconnect.ros.callback_watch); the first messages of an entity created while spinning
        may run before it is wrapped, which only delays their hand-off to the idle check.
        """
        self.wrap_callbacks(node)
        if self._elastic is None and self._has_actions():
            self._go_elastic()

    # -- spinning ------------------------------------------------------------------------------
    @property
    def mode(self) -> str:
        """``'events'`` (EventsExecutor, callbacks inline) or ``'elastic'`` (after a block)."""
        return "events" if self._elastic is None else "elastic"

    @property
    def is_spinning(self) -> bool:
        """True while ``spin()`` runs in some thread."""
        return self._spinning and not self._stopping

    def spin(self) -> None:
        """Run callbacks until ``stop()`` or shutdown (in this thread, and others when needed).

        When a blocking wait already started spinning in the background (nothing spun the node
        then), this call waits for that spinning to end instead.
        """
        with self._lock:
            background = self._background
            if self._spinning and background is None:
                raise RuntimeError("AgentExecutor.spin() is already running")
            if not self._spinning:
                self._spinning = True
                background = None
        if background is not None:
            background.join()
            return
        self._spin_here()

    def runs_callbacks_here(self) -> bool:
        """Whether this thread runs the executor's callbacks: its dispatching loop, or the
        elastic executor's threads once a long callback moved the node there."""
        current = threading.current_thread()
        if current.ident == self._dispatcher or current is self._elastic_thread:
            return True
        elastic = self._elastic
        return elastic is not None and elastic.runs_on(current)

    def spin_in_background(self) -> None:
        """Start spinning on a thread of its own, unless something spins already.

        Waits that need callbacks to run call this rather than spinning on the caller's
        thread: a callback run inline there could be another agent's long work (an action
        goal, a slow subscriber), and the caller's timeout would go unchecked until it ends.
        """
        with self._lock:
            if self._spinning or self._stopping:
                return
            self._spinning = True
            thread = threading.Thread(
                target=self._spin_reporting, name="pyconnect-executor-spin", daemon=True
            )
            self._background = thread
        thread.start()

    def _spin_reporting(self) -> None:
        try:
            self._spin_here()
        except BaseException as error:  # the thread ends: nothing above it would report
            self._callback_raised(error)

    def _spin_here(self) -> None:
        """The dispatching loop, on this thread (``_spinning`` is already set)."""
        me = threading.get_ident()
        with self._lock:
            self._dispatcher = me
        try:
            self.adopt()
            self._start_monitor()
            while not self._stopping:
                if self._elastic is not None:
                    self._supervise_elastic()
                    continue
                events = self._events
                with self._spin_lock:  # stop() wakes this spin_once only if it sees it begin
                    if self._stopping:
                        break
                    # A spin_once() that dispatched before this loop started resets it when done.
                    self._dispatcher = me
                    self._spun = events
                try:
                    events.spin_once(timeout_sec=IDLE_TICK)
                except (ShutdownException, ExternalShutdownException):
                    self._stopping = True
                except BaseException as error:  # a SystemExit would end the loop unseen
                    self._callback_raised(error)
                finally:
                    with self._spin_lock:
                        self._spun = None
                self._returns += 1
                if events is not self._events or self._elastic is not None:
                    self._retire(events)
        finally:
            with self._lock:
                self._spinning = False
                self._dispatcher = None

    def _wrap(
        self, callback: Callable[..., Any], group: Any, entity: Any, *, takes_args: bool = True
    ) -> Callable[..., Any]:
        # The executor a callback runs on catches ``Exception`` only (rclpy's Task, the elastic
        # executor's threads): what else a callback raises is handled here, wherever it runs.
        def guarded(*args: Any) -> Any:
            try:
                return callback(*args)
            except Exception:
                raise
            except BaseException as error:
                self._callback_raised(error)
                return None

        return super()._wrap(guarded, group, entity, takes_args=takes_args)

    def _callback_raised(self, error: BaseException) -> None:
        """Report what a callback raised; a ``SystemExit`` or ``KeyboardInterrupt`` (a handler's
        ``sys.exit()``) also shuts the nodes down, so ``spin()`` returns."""
        self._report(error)
        if not isinstance(error, (SystemExit, KeyboardInterrupt)):
            return
        for node in list(self._nodes):
            shutdown = getattr(node, "shutdown", None)
            if shutdown is None:  # a plain rclpy node: only the executor stops
                self.stop()
            elif self.runs_callbacks_here():
                shutdown()  # CustomNode: on a thread of its own, once this callback has ended
            else:
                threading.Thread(
                    target=shutdown, name="pyconnect-exit-shutdown", daemon=True
                ).start()

    def spin_once(self, timeout_sec: float | None = None) -> None:
        """Run at most one callback in this thread (rclpy's executor API)."""
        elastic = self._elastic
        if elastic is not None:
            elastic.spin_once(timeout_sec)
            return
        with self._lock:
            if self._dispatcher is not None or self._spinning:
                # Someone dispatches already: just let time pass.
                dispatching = True
            else:
                dispatching = False
                self._dispatcher = threading.get_ident()
        if dispatching:
            self._stopped.wait(timeout_sec or 0.0)
            return
        with self._spin_lock:
            events = self._spun = self._events
        try:
            events.spin_once(timeout_sec=timeout_sec)
        except (ShutdownException, ExternalShutdownException):
            pass
        finally:
            with self._spin_lock:
                self._spun = None
            with self._lock:
                if self._dispatcher == threading.get_ident():
                    self._dispatcher = None
            if events is not self._events or self._elastic is not None:
                self._retire(events)

    def spin_until_future_complete(self, future: Future, timeout_sec: float | None = None) -> None:
        """Spin, or wait for the spinning thread, until ``future`` is done (rclpy's API)."""
        done = threading.Event()
        future.add_done_callback(lambda _future: done.set())
        if not future.done():
            self.wait_for(done, timeout_sec, poll=future.done)

    def wait_for(
        self,
        event: EventLike,
        timeout_sec: float | None,
        *,
        poll: Callable[[], bool] | None = None,
    ) -> bool:
        """Wait until ``event`` is set by a callback; True if it was, False on timeout.

        The caller never runs callbacks itself: inside a callback on the dispatching thread
        this first moves the node to the elastic executor (inside one of its callbacks, it
        passes the turn on), so the callback that sets ``event`` can run elsewhere; when
        nothing spins, spinning starts in the background. So the timeout always holds.
        """
        finished = poll if poll is not None else event.is_set
        deadline = None if timeout_sec is None else time.monotonic() + timeout_sec
        me = threading.get_ident()
        while not event.is_set() and not finished():
            remaining = None if deadline is None else deadline - time.monotonic()
            if remaining is not None and remaining <= 0:
                return False
            if self._dispatcher == me and self._elastic is None:
                self._go_elastic()
            elastic = self._elastic
            if elastic is not None:
                elastic.release_turn()
            if self._stopping:
                return event.is_set() or finished()
            if not self._spinning:
                self.spin_in_background()
            event.wait(IDLE_TICK if remaining is None else min(remaining, IDLE_TICK))
        return True

    def wake(self) -> None:
        """Make the executor notice new entities (rclpy's API)."""
        elastic = self._elastic
        if elastic is not None:
            elastic.wake()
        else:
            self._events.wake()

    def stop(self) -> None:
        """Make ``spin()`` return; callbacks in progress finish on their own threads."""
        with self._spin_lock:
            self._stopping = True
            # A task is a "user callback": it ends the dispatcher's spin_once at once. Made only
            # for a spin_once under way on another thread, and once: a task its EventsExecutor
            # never runs stays alive for ever (the C++ executor keeps it, even once shut down).
            here = self._dispatcher == threading.get_ident()
            spun = None if self._woken or here else self._spun
            self._woken = self._woken or spun is not None
        self._stopped.set()
        self._monitor_wake.set()
        elastic = self._elastic
        if elastic is not None:
            elastic.stop()
        if spun is not None:
            with contextlib.suppress(Exception):
                spun.create_task(_nothing)

    def join(self, timeout_sec: float | None = None) -> None:
        """Wait for the monitor and the elastic executor's threads to end (after ``stop()``)."""
        current = threading.current_thread()
        for thread in (self._background, self._monitor, self._elastic_thread):
            if thread is not None and thread is not current and thread.is_alive():
                thread.join(timeout_sec)
        elastic = self._elastic
        if elastic is not None:
            elastic.join(timeout_sec)

    def shutdown(self, timeout_sec: float | None = None) -> bool:
        self.stop()
        self.join(timeout_sec)
        elastic = self._elastic
        if elastic is not None:
            elastic.shutdown(timeout_sec)
        with contextlib.suppress(Exception):
            self._events.shutdown(timeout_sec=timeout_sec)
        for events in self._retired:
            with contextlib.suppress(Exception):
                events.shutdown(timeout_sec=0.0)
        self._retired.clear()
        return True


def _nothing() -> None:
    """A task that only ends a ``spin_once``."""
