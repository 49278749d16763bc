"""The ElasticExecutor's wait: one wait set kept between wake-ups while the nodes' entities stay.

Why (bench/agents.py, "120 agents" rows): rclpy's ``Executor._wait_for_ready_callbacks``
gathers every entity of every node, enters each handle through an ``ExitStack``, builds a new
``WaitSet`` and adds each entity on every wake-up. A node with 120 agents has ~310 entities
(180 of them QoS event handlers, two per publisher and subscription), so each wake-up cost
~1.5-3 ms and ten 2 Hz timers kept the node at 3.5-6.5 % of a core doing nothing. Here:

- the plan (the entities sorted by kind with their handles, callback groups and pointers, and a
  wait set sized for all of them) is built when the nodes' entity lists change (compared by
  identity on each wake-up, microseconds) and kept otherwise. It keeps every handle entered (in
  use): rclpy defers the destruction of an entity destroyed meanwhile until the plan lets go of
  it, which happens on the wake-up that the destroying node sends its executor, so no wait ever
  sees a freed handle;
- a wake-up only clears the wait set and adds the handles of the entities that may run now (no
  handler pending, callback group free), like rclpy's ``can_execute``;
- QoS event handlers, which hardly ever fire, wait on a thread of their own
  (:class:`EventWaiter`) that wakes the executor when one is ready;
- the executor's guard condition is a :class:`WakeGuard`: a trigger reaches rcl only while a
  thread prepares or runs a wait. Every handler triggers it twice (rclpy), which would cost a
  second full wake-up per callback; a callback that ran inline needs none, as the next
  wait reads the state afresh after the flag is set;
- a timeout is the wait's own, not an rcl timer made per call.

The generator keeps rclpy's contract (``Executor.wait_for_ready_callbacks`` calls it): it yields
``(handler task, entity, node)`` and raises rclpy's Timeout/Shutdown/ConditionReached exceptions.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Callable, Generator
from typing import Any

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.event_handler import EventHandler
from rclpy.executors import (
    ConditionReachedException,
    ExternalShutdownException,
    ShutdownException,
    TimeoutException,
)
from rclpy.guard_condition import GuardCondition
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.waitable import NumberOfEntities

_FREE, _EXCLUSIVE, _ASK = 0, 1, 2
"""How a callback group says whether its entity may run: always, while no callback of the
group runs (read without its lock: a stale answer costs one spare wake-up, the handler asks
again), or by calling its ``can_execute``."""

Ready = tuple[Any, Any, Node]


def _group_kind(group: Any) -> int:
    if type(group) is ReentrantCallbackGroup:
        return _FREE
    if type(group) is MutuallyExclusiveCallbackGroup and hasattr(group, "_active_entity"):
        return _EXCLUSIVE
    return _ASK


def _node_lists(node: Node) -> tuple[list[Any], ...]:
    return (
        list(node.subscriptions),
        list(node.timers),
        list(node.clients),
        list(node.services),
        list(node.guards),
        list(node.waitables),
    )


class _Entry:
    """One entity of the plan: its handle (entered), callback group and node."""

    __slots__ = ("entity", "group", "handle", "kind", "node")

    def __init__(self, entity: Any, handle: Any, node: Node) -> None:
        self.entity = entity
        self.handle = handle
        self.group = entity.callback_group
        self.kind = _group_kind(self.group)
        self.node = node

    def usable(self) -> bool:
        if self.entity._executor_event:
            return False
        if self.kind == _EXCLUSIVE:
            return self.group._active_entity is None
        return self.kind == _FREE or bool(self.group.can_execute(self.entity))


class _Plan:
    """The entities of some nodes, their handles entered, and wait sets sized for them."""

    def __init__(self, nodes: list[Node], executor: Any) -> None:
        self.nodes = nodes
        self.lists = [_node_lists(node) for node in nodes]
        self.stack = contextlib.ExitStack()
        self.subscriptions: list[_Entry] = []
        self.timers: list[_Entry] = []
        self.clients: list[_Entry] = []
        self.services: list[_Entry] = []
        self.guards: list[_Entry] = []
        self.waitables: list[_Entry] = []
        self.events: dict[Any, Node] = {}
        count = NumberOfEntities()
        try:
            for node, (subs, timers, clients, services, guards, waitables) in zip(
                nodes, self.lists, strict=True
            ):
                for kind, entities in (
                    (self.subscriptions, subs),
                    (self.timers, timers),
                    (self.clients, clients),
                    (self.services, services),
                    (self.guards, guards),
                ):
                    for entity in entities:
                        if self._enter(entity.handle):
                            kind.append(_Entry(entity, entity.handle, node))
                for waitable in waitables:
                    if isinstance(waitable, EventHandler):
                        self.events[waitable] = node
                    elif self._enter(waitable):
                        self.waitables.append(_Entry(waitable, None, node))
                        count += waitable.get_num_entities()
            self.own_guards = [executor._guard.handle, executor._sigint_gc.handle]
            for handle in self.own_guards:
                self.stack.enter_context(handle)
            context = executor.context.handle
            self.stack.enter_context(context)
            self.wait_set = _rclpy.WaitSet(
                len(self.subscriptions) + count.num_subscriptions,
                len(self.guards) + len(self.own_guards) + count.num_guard_conditions,
                len(self.timers) + count.num_timers,
                len(self.clients) + count.num_clients,
                len(self.services) + count.num_services,
                count.num_events,
                context,
            )
        except BaseException:
            self.stack.close()
            raise
        self.by_pointer = {
            kind: {entry.handle.pointer: entry for entry in entries}
            for kind, entries in (
                ("subscription", self.subscriptions),
                ("timer", self.timers),
                ("client", self.clients),
                ("service", self.services),
            )
        }

    def _enter(self, handle: Any) -> bool:
        try:
            self.stack.enter_context(handle)
        except Exception:  # InvalidHandle: destroyed meanwhile
            return False
        return True

    def is_current(self, nodes: list[Node]) -> bool:
        return nodes == self.nodes and all(
            _node_lists(node) == lists for node, lists in zip(nodes, self.lists, strict=True)
        )

    def release(self) -> None:
        self.stack.close()


class PlannedWaits:
    """An executor's wait with a kept plan; ``ready_callbacks`` is its
    ``_wait_for_ready_callbacks``. ``close()`` lets go of every handle (after spinning ends)."""

    def __init__(self, executor: Any) -> None:
        self._executor = executor
        self._lock = threading.Lock()
        self._plan: _Plan | None = None
        self._closed = False
        self._events = EventWaiter(executor.context, executor.wake)
        self._handed: dict[Any, Any] = {}
        self.plans = 0
        """Plans built so far (tests and diagnostics)."""
        self.waits = 0
        """Waits on the plan's wait set so far (tests and diagnostics)."""

    def close(self) -> None:
        """Stop the event thread and release the plan's handles (waits for a running wait)."""
        self._events.stop()
        with self._lock:
            self._closed = True
            if self._plan is not None:
                self._plan.release()
                self._plan = None

    def join(self, timeout_sec: float | None = None) -> None:
        self._events.join(timeout_sec)

    def _current_plan(self, nodes: list[Node]) -> _Plan:
        plan = self._plan
        if plan is None or not plan.is_current(nodes):
            if plan is not None:
                plan.release()
            self._plan = None
            plan = _Plan(nodes, self._executor)
            self._plan = plan
            self.plans += 1
            self._events.watch(list(plan.events))
        return plan

    def ready_callbacks(
        self,
        timeout_sec: float | None,
        nodes: list[Node] | None,
        condition: Callable[[], bool],
        guard: WakeGuard,
    ) -> Generator[Ready, None, None]:
        """Yield callbacks ready to run, like rclpy's ``_wait_for_ready_callbacks``; ``guard``
        is the executor's guard condition (its flag is set from here to the end of the wait)."""
        executor = self._executor
        deadline = (
            None
            if timeout_sec is None or timeout_sec < 0
            else time.monotonic() + max(0.0, timeout_sec)
        )
        yielded = False
        while True:
            # From here on a trigger (a handler ending elsewhere, wake(), a new task) reaches
            # the wait: everything it announces is read below or wakes the wait.
            guard.waiting = True
            if yielded or executor._is_shutdown or condition():
                guard.waiting = False
                break
            ready: list[tuple[str, _Entry]] = []
            with self._lock:
                if self._closed:
                    guard.waiting = False
                    raise ShutdownException()
                nodes_to_use = executor.get_nodes() if nodes is None else list(nodes)
                plan = self._current_plan(nodes_to_use)
            # Tasks in progress before new work (as rclpy: newest first).
            with executor._tasks_lock:
                tasks = list(executor._tasks)
            if tasks:
                for task, entity, node in reversed(tasks):
                    if (
                        not task.executing()
                        and not task.done()
                        and (node is None or node in nodes_to_use)
                    ):
                        yielded = True
                        yield task, entity, node
                with executor._tasks_lock:
                    executor._tasks = [
                        each
                        for each in executor._tasks
                        if not each[0].done() and not each[0].cancelled()
                    ]
            # QoS events the event thread found ready.
            for waitable, task in list(self._handed.items()):
                if task.done():
                    del self._handed[waitable]
                    self._events.hand_back(waitable)
            for waitable in self._events.pending():
                node = plan.events.get(waitable)
                if (
                    node is not None
                    and waitable not in self._handed
                    and executor.can_execute(waitable)
                ):
                    handler = executor._make_handler(waitable, node, executor._take_waitable)
                    self._handed[waitable] = handler
                    yielded = True
                    yield handler, waitable, node
            with self._lock:
                if self._closed or self._plan is not plan:
                    continue
                wait_set = plan.wait_set
                wait_set.clear_entities()
                for entry in plan.subscriptions:
                    if entry.usable():
                        wait_set.add_subscription(entry.handle)
                for entry in plan.clients:
                    if entry.usable():
                        wait_set.add_client(entry.handle)
                for entry in plan.services:
                    if entry.usable():
                        wait_set.add_service(entry.handle)
                for entry in plan.timers:
                    if entry.usable():
                        wait_set.add_timer(entry.handle)
                guards = [entry for entry in plan.guards if entry.usable()]
                for entry in guards:
                    if entry.entity._executor_triggered:
                        # Retrigger a guard condition that was triggered but not handled.
                        entry.entity.trigger()
                    wait_set.add_guard_condition(entry.handle)
                for handle in plan.own_guards:
                    wait_set.add_guard_condition(handle)
                waitables = [entry for entry in plan.waitables if entry.usable()]
                for entry in waitables:
                    entry.entity.add_to_wait_set(wait_set)
                if deadline is None:
                    timeout_nsec = -1
                else:
                    timeout_nsec = max(0, int((deadline - time.monotonic()) * 1e9))
                self.waits += 1
                try:
                    wait_set.wait(timeout_nsec)
                finally:
                    guard.waiting = False
                if executor._is_shutdown:
                    raise ShutdownException()
                if not executor.context.ok():
                    raise ExternalShutdownException()
                guards_ready = wait_set.get_ready_entities("guard_condition")
                for entry in guards:
                    if entry.handle.pointer in guards_ready:
                        entry.entity._executor_triggered = True
                ready.extend(
                    ("waitable", entry) for entry in waitables if entry.entity.is_ready(wait_set)
                )
                for kind in ("timer", "subscription"):
                    entries = plan.by_pointer[kind]
                    ready.extend(
                        (kind, entries[pointer])
                        for pointer in wait_set.get_ready_entities(kind)
                        if pointer in entries
                    )
                ready.extend(
                    ("guard", entry) for entry in guards if entry.entity._executor_triggered
                )
                for kind in ("client", "service"):
                    entries = plan.by_pointer[kind]
                    ready.extend(
                        (kind, entries[pointer])
                        for pointer in wait_set.get_ready_entities(kind)
                        if pointer in entries
                    )
            takes = {
                "waitable": executor._take_waitable,
                "timer": executor._take_timer,
                "subscription": executor._take_subscription,
                "guard": executor._take_guard_condition,
                "client": executor._take_client,
                "service": executor._take_service,
            }
            for kind, entry in ready:
                entity = entry.entity
                if kind == "timer" and not _timer_ready(entity):
                    # rcl reports cancelled timers as ready.
                    continue
                if entity.callback_group.can_execute(entity):
                    handler = executor._make_handler(entity, entry.node, takes[kind])
                    yielded = True
                    yield handler, entity, entry.node
            if deadline is not None and time.monotonic() >= deadline:
                raise TimeoutException()
        if executor._is_shutdown:
            raise ShutdownException()
        if condition():
            raise ConditionReachedException()


class WakeGuard:
    """An executor's guard condition whose ``trigger()`` reaches rcl only while ``waiting``.

    Whatever a trigger announces (an entity free again, a new task or node, a stop) is state
    that the waiting thread reads after setting ``waiting``; while nobody waits, the next wait
    reads it anyway, and a trigger would only cost that wait a spare wake-up.
    """

    __slots__ = ("_guard", "waiting")

    def __init__(self, guard: GuardCondition) -> None:
        self._guard = guard
        self.waiting = False

    @property
    def handle(self) -> Any:
        return self._guard.handle

    def trigger(self) -> None:
        if self.waiting:
            self._guard.trigger()

    def destroy(self) -> None:
        self._guard.destroy()


def _timer_ready(timer: Any) -> bool:
    try:
        with timer.handle:
            return bool(timer.handle.is_timer_ready())
    except Exception:  # InvalidHandle: destroyed meanwhile
        return False


class EventWaiter:
    """A thread waiting on QoS event handlers; wakes the executor when one is ready.

    A handler found ready stays out of this thread's wait set until the executor has run it
    (``hand_back``): the event stays ready in the middleware until it is taken.
    """

    def __init__(self, context: Any, wake: Callable[[], None]) -> None:
        self._context = context
        self._wake = wake
        self._cond = threading.Condition()
        self._members: list[Any] = []
        self._pending: dict[Any, None] = {}
        self._guard: GuardCondition | None = None
        self._stopped = False
        self._thread: threading.Thread | None = None

    def watch(self, handlers: list[Any]) -> None:
        """Wait on ``handlers`` from now on (the thread starts on the first non-empty list)."""
        with self._cond:
            if self._stopped or handlers == self._members:
                return
            self._members = handlers
            self._pending = {each: None for each in self._pending if each in handlers}
            if self._thread is None and handlers:
                self._guard = GuardCondition(None, None, context=self._context)
                self._thread = threading.Thread(
                    target=self._run, name="pyconnect-executor-events", daemon=True
                )
                self._thread.start()
        self._trigger()

    def pending(self) -> list[Any]:
        """The handlers found ready and not yet handed back, oldest first."""
        if not self._pending:
            return []
        with self._cond:
            return list(self._pending)

    def hand_back(self, handler: Any) -> None:
        """``handler`` ran (or will be found ready again): wait on it again."""
        with self._cond:
            self._pending.pop(handler, None)
        self._trigger()

    def stop(self) -> None:
        with self._cond:
            self._stopped = True
        self._trigger()

    def join(self, timeout_sec: float | None = None) -> None:
        thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout_sec)

    def _trigger(self) -> None:
        guard = self._guard
        if guard is not None:
            with contextlib.suppress(Exception):
                guard.trigger()

    def _run(self) -> None:
        guard = self._guard
        assert guard is not None
        try:
            while True:
                with self._cond:
                    if self._stopped:
                        return
                    waiting = [each for each in self._members if each not in self._pending]
                ready = self._wait(guard, waiting)
                if not self._context.ok():
                    return
                if ready:
                    with self._cond:
                        for each in ready:
                            if each in self._members:
                                self._pending[each] = None
                    with contextlib.suppress(Exception):
                        self._wake()
        except Exception:  # the context went away under us: nothing left to watch
            return
        finally:
            with contextlib.suppress(Exception):
                guard.destroy()

    def _wait(self, guard: GuardCondition, waiting: list[Any]) -> list[Any]:
        with contextlib.ExitStack() as stack:
            stack.enter_context(guard.handle)
            entered = []
            for handler in waiting:
                try:
                    stack.enter_context(handler)
                except Exception:  # InvalidHandle: destroyed meanwhile
                    continue
                entered.append(handler)
            stack.enter_context(self._context.handle)
            wait_set = _rclpy.WaitSet(0, 1, 0, 0, 0, len(entered), self._context.handle)
            wait_set.clear_entities()
            wait_set.add_guard_condition(guard.handle)
            for handler in entered:
                handler.add_to_wait_set(wait_set)
            wait_set.wait(-1)
            return [handler for handler in entered if handler.is_ready(wait_set)]
