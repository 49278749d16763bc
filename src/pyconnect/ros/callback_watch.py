"""Watching an ``AgentExecutor``'s callbacks: a wrapper per entity and a monitor thread.

The wrapper notes which callback runs (a sequence number and the callback's group and
entity); the monitor thread reads that and moves the node to the elastic executor when the
dispatching thread is stuck: the same callback ran through a whole ``handoff_after``, or, for
what is not wrapped (an action goal), the dispatcher stopped returning from its idle waits.

The watch costs nothing while the node is idle: the monitor parks until a callback starts,
looks every ``BUSY_TICK`` while callbacks keep coming, every ``handoff_after`` while one is
running, and otherwise checks every ``IDLE_TICK`` seconds whether the dispatching thread still
returns. A slow callback is thus noticed after 20-120 ms. While the node is on the elastic
executor (which watches its own callbacks) the monitor sleeps; the move back wakes it, so the
first slow callback afterwards is noticed as quickly. The wrapper runs per message on a
cold cache (bench/agents.py: the whole tick of a 100 Hz timer is ~200 us of CPU there), so it
is a few attribute stores and takes no lock unless a move held its callback's group. Only the
held callback's own return ends the hold: callbacks of other agents, which go on running on the
elastic executor meanwhile, leave it alone.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import inspect
import threading
import time
import weakref
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from rclpy.node import Node

from pyconnect.ros.waiting import running_thread

IDLE_TICK = 0.25
"""Seconds between the dispatching thread's returns while idle (it notices ``stop()`` then)."""

BUSY_TICK = 0.1
"""Seconds between the monitor's looks while callbacks come but none was running at the last."""

_WRAPPED = "_pyconnect_wrapped"

_WATCHES: weakref.WeakKeyDictionary[Node, CallbackWatch] = weakref.WeakKeyDictionary()
"""The watch over each node's callbacks: found here by what re-creates an entity later, away
from ``add_agent`` (pyconnect.ros.following_subscription), which knows the rclpy node only."""


def watch_new_entities(node: Node) -> None:
    """Wrap the callbacks of ``node``'s entities made since its executor last looked, as
    ``add_agent`` does for a new agent; nothing when no ``AgentExecutor`` runs ``node``."""
    watch = _WATCHES.get(node)
    if watch is not None:
        watch.wrap_callbacks(node)


class CallbackWatch:
    """The part of ``AgentExecutor`` that wraps callbacks and watches for long ones."""

    # Set up by AgentExecutor.__init__ (shared with the executor's own code).
    _lock: threading.Lock
    _nodes: list[Node]
    _handoff_after: float
    _stopping: bool
    _spinning: bool
    _dispatcher: int | None
    _returns: int
    _elastic: Any
    _seq: int
    _running: tuple[Any, Any] | None
    _held: tuple[Any, Any] | None
    _monitor: threading.Thread | None
    _monitor_wake: threading.Event
    _monitor_parked: bool

    if TYPE_CHECKING:  # AgentExecutor's

        def _go_elastic(self) -> None: ...

    def _watch(self, node: Node) -> None:
        """Let ``watch_new_entities(node)`` find this watch (the node was added)."""
        _WATCHES[node] = self

    def _unwatch(self, node: Node) -> None:
        """The node was removed: ``watch_new_entities(node)`` no longer wraps for this watch."""
        if _WATCHES.get(node) is self:
            del _WATCHES[node]

    def wrap_callbacks(self, node: Node | None = None) -> None:
        """Wrap the callbacks of entities created since the last call (cheap; call after adding).

        The wrapper tells the monitor which callback runs and since when; the first messages of
        an entity created while spinning may run before it is wrapped, which only delays their
        hand-off to the idle check.
        """
        for each in [node] if node is not None else list(self._nodes):
            for subscription in list(each.subscriptions):
                if not getattr(subscription.callback, _WRAPPED, False):
                    subscription.callback = self._wrap(
                        subscription.callback, subscription.callback_group, subscription
                    )
            for service in list(each.services):
                if not getattr(service.callback, _WRAPPED, False):
                    service.callback = self._wrap(service.callback, service.callback_group, service)
            for timer in list(each.timers):
                if not getattr(timer.callback, _WRAPPED, False):
                    timer.callback = self._wrap_timer(timer.callback, timer.callback_group, timer)

    def _wrap(
        self, callback: Callable[..., Any], group: Any, entity: Any, *, takes_args: bool = True
    ) -> Callable[..., Any]:
        # Runs per message on a cold cache: a few attribute stores, no lock unless the
        # callback's agent was held by a move to the elastic executor (see ``_go_elastic``).
        token = (group, entity)

        def run(*args: Any) -> Any:
            self._seq += 1
            self._running = token
            if self._monitor_parked:
                self._monitor_wake.set()
            try:
                return callback(*args)
            finally:
                self._running = None
                if self._held is token:  # this agent's hold only: another agent's end is not ours
                    self._release_held()

        def tick() -> Any:
            self._seq += 1
            self._running = token
            if self._monitor_parked:
                self._monitor_wake.set()
            try:
                return callback()
            finally:
                self._running = None
                if self._held is token:  # this agent's hold only: another agent's end is not ours
                    self._release_held()

        wrapped = run if takes_args else tick
        setattr(wrapped, _WRAPPED, True)
        return wrapped

    def _wrap_timer(
        self, callback: Callable[..., Any], group: Any, entity: Any
    ) -> Callable[..., Any]:
        # EventsExecutor passes a TimerInfo only to callbacks that take an argument.
        takes_args = bool(inspect.signature(callback).parameters)
        return self._wrap(callback, group, entity, takes_args=takes_args)

    def _release_held(self) -> None:
        """End the hold ``_go_elastic`` put on the group of a callback that has returned."""
        with self._lock:
            held, self._held = self._held, None
        if held is not None:
            held[0].ending_execution(held[1])

    def _start_monitor(self) -> None:
        with self._lock:
            self._monitor = running_thread(
                self._monitor, self._monitor_loop, "pyconnect-executor-monitor"
            )

    def _monitor_loop(self) -> None:
        """Move to the elastic executor when the dispatching thread is stuck in a callback."""
        last_seq, last_returns, quiet, ticking = self._seq, self._returns, 0, True
        running: tuple[Any, Any] | None = None
        while not self._stopping:
            if self._elastic is not None:
                # The elastic executor's own monitor watches its callbacks meanwhile. The move
                # back wakes us (wrappers do not: not parked); the timeout only notices a
                # shutdown that the elastic executor saw on its own thread.
                self._monitor_wake.wait(IDLE_TICK * 4)
                self._monitor_wake.clear()
                # Start afresh, parked: nothing of the looks before the move is still true.
                last_seq, last_returns, quiet, ticking = self._seq, self._returns, 0, False
                running = None
                continue
            started = time.monotonic()
            if ticking:
                # Short ticks only while a callback was running at the last look: callbacks
                # that come often but end quickly cost a wake-up every BUSY_TICK.
                self._monitor_wake.wait(
                    self._handoff_after
                    if running is not None
                    else max(BUSY_TICK, self._handoff_after)
                )
            else:
                # Parked: a wrapped callback wakes us; the idle tick catches unwrapped ones. A
                # callback that started since the last look did not see the flag: look now.
                self._monitor_parked = True
                if self._seq == last_seq and self._running is None:
                    self._monitor_wake.wait(IDLE_TICK * 2)
                self._monitor_parked = False
            self._monitor_wake.clear()
            if self._stopping:
                return
            waited = time.monotonic() - started
            seq, running, returns = self._seq, self._running, self._returns
            if self._elastic is None and self._dispatcher is not None:
                # The same callback (same sequence number) ran through a whole tick.
                stuck_in_wrapped = (
                    ticking
                    and running is not None
                    and seq == last_seq
                    and waited >= self._handoff_after
                )
                # While idle the dispatcher returns every IDLE_TICK; twice silent means stuck.
                stuck_unwrapped = (
                    not ticking and running is None and returns == last_returns and self._spinning
                )
                quiet = quiet + 1 if stuck_unwrapped else 0
                if stuck_in_wrapped or quiet >= 2:
                    self._go_elastic()
                    quiet = 0
            ticking = running is not None or seq != last_seq
            last_seq, last_returns = seq, returns
