"""Moving an ``AgentExecutor``'s nodes to a fresh elastic executor when a callback blocks, and back.

The move keeps the blocked callback's agent from starting another callback until it returns
(its callback group stays held), starts the elastic executor on a thread of its own, and, once
that executor has been calm for ``CALM_AFTER`` seconds, moves the nodes to a new
``EventsExecutor`` (one whose callback ran during the move is retired, never reused). Nodes with
action agents stay elastic. Why the two executors: pyconnect.ros.agent_executor.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import contextlib
import functools
import os
import sys
import threading
from collections.abc import Callable
from typing import IO, TYPE_CHECKING, Any

from rclpy.action import ActionClient, ActionServer
from rclpy.context import Context
from rclpy.executors import ExternalShutdownException, ShutdownException
from rclpy.experimental import EventsExecutor
from rclpy.node import Node

from pyconnect.ros.callback_watch import IDLE_TICK, CallbackWatch
from pyconnect.ros.executor import ElasticExecutor

CALM_AFTER = 1.0
"""Seconds without a running callback or a hand-off before the node returns to EventsExecutor."""


class ExecutorMoves(CallbackWatch):
    """The part of ``AgentExecutor`` that moves its nodes between the two executors."""

    # Set up by AgentExecutor.__init__ (shared with the executor's own code).
    context: Context
    _on_error: Callable[[BaseException], None] | None
    _events: Any
    _elastic_thread: threading.Thread | None
    _stopped: threading.Event
    handoffs: int

    if TYPE_CHECKING:  # AgentExecutor's

        def adopt(self, node: Node | None = None) -> None: ...

    def _go_elastic(self) -> None:
        """Move the nodes to a fresh ElasticExecutor spinning on its own thread."""
        with self._lock:
            if self._elastic is not None or self._stopping:
                return
            running = self._running
            if running is not None and self._held is None:
                group, entity = running
                # Keep the running callback's agent from starting another callback meanwhile.
                if group.beginning_execution(entity):
                    self._held = running
                    # The callback clears ``_running`` and then looks at ``_held`` without the
                    # lock: if it returned between our two looks (another agent's callback may
                    # run by now), the hold is ours to end: only its own return ends it.
                    if self._running is not running:
                        self._held = None
                        group.ending_execution(entity)
            elastic = ElasticExecutor(
                context=self.context, handoff_after=self._handoff_after, on_error=self._on_error
            )
            self._elastic = elastic
            self.handoffs += 1
            nodes = list(self._nodes)
        for node in nodes:
            node.executor = elastic
        if self._spinning:
            self._start_elastic_thread()

    def _start_elastic_thread(self) -> None:
        with self._lock:
            elastic = self._elastic
            if elastic is None or self._elastic_thread is not None:
                return
            self._elastic_thread = threading.Thread(
                target=self._spin_elastic,
                args=(elastic,),
                name="pyconnect-executor-elastic",
                daemon=True,
            )
            self._elastic_thread.start()

    def _spin_elastic(self, elastic: ElasticExecutor) -> None:
        try:
            elastic.spin()
        except (ShutdownException, ExternalShutdownException):
            self._stopping = True
        except Exception as error:
            self._report(error)

    def _retire(self, events: Any) -> None:
        """Drop an EventsExecutor the nodes left while one of its callbacks ran (never reused)."""
        # Its queued events are stale: the messages are still in the middleware's queues and the
        # new executor takes them. Shutting it down unregisters its timers and listeners.
        with contextlib.suppress(Exception):
            events.shutdown(timeout_sec=1.0)

    def _supervise_elastic(self) -> None:
        """On the dispatching thread while elastic: return to EventsExecutor once calm."""
        elastic = self._elastic
        if elastic is None:
            return
        self._start_elastic_thread()
        if self._has_actions():
            # Stays elastic while it has actions: look again now and then only (each wake-up of
            # a sleeping thread costs ~0.1-0.2 ms of CPU here).
            self._stopped.wait(CALM_AFTER)
            return
        if self._stopped.wait(IDLE_TICK):
            return
        if not elastic.is_calm(CALM_AFTER):
            return
        with self._lock:
            if self._held is not None or self._stopping:
                return
            events = self._new_events()
        elastic.stop()
        thread = self._elastic_thread
        if thread is not None:
            thread.join()
        elastic.join()
        with self._lock:
            self._events = events
            self._elastic = None
            self._elastic_thread = None
            nodes = list(self._nodes)
        # The watch sleeps while elastic: left asleep, it would miss the next slow callback on
        # EventsExecutor for up to a second, and every other agent would wait that long.
        self._monitor_wake.set()
        for node in nodes:
            node.executor = events
        self.adopt()

    def _has_actions(self) -> bool:
        # Action servers and clients stay on the elastic executor: their futures and goal tasks
        # are bound to the executor that made them and would be stranded by a move.
        return any(
            isinstance(waitable, (ActionServer, ActionClient))
            for node in list(self._nodes)
            for waitable in node.waitables
        )

    def _new_events(self) -> Any:
        if _has_usable_stderr():
            return EventsExecutor(context=self.context)
        # rclpy's EventsExecutor calls faulthandler.enable(), which needs sys.stderr's file
        # descriptor and raises without one (``2>&-``, daemons, pythonw): it gets devnull.
        saved = sys.stderr
        sys.stderr = _devnull()
        try:
            return EventsExecutor(context=self.context)
        finally:
            sys.stderr = saved

    def _report(self, error: BaseException) -> None:
        if self._on_error is not None:
            self._on_error(error)
        else:
            import traceback

            traceback.print_exception(error)


@functools.cache
def _devnull() -> IO[str]:
    # Opened once and never closed: faulthandler keeps writing to its file descriptor, which
    # a closed file would hand to the next file opened.
    return open(os.devnull, "w")


def _has_usable_stderr() -> bool:
    """Whether ``sys.stderr`` has the file descriptor faulthandler.enable() needs."""
    try:
        return sys.stderr is not None and sys.stderr.fileno() >= 0
    except (AttributeError, OSError, ValueError):  # io.UnsupportedOperation is both
        return False
