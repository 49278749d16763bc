"""The ElasticExecutor's wait: one wait set kept between wake-ups, quiet entities left out.

Why (bench/agents.py, "120 agents" rows): rclpy's ``Executor._wait_for_ready_callbacks``
gathers every entity of every node, enters each handle through an ``ExitStack``, builds a new
``WaitSet`` and adds each entity on every wake-up. A node with 120 agents has ~310 entities
(180 of them QoS event handlers, two per publisher and subscription), so each wake-up cost
~1.5-3 ms and ten 2 Hz timers kept the node at 3.5-6.5 % of a core doing nothing. Here:

- the plan (the entities sorted by kind with their handles, callback groups and pointers, and a
  wait set sized for all of them) is built when the nodes' entity lists change (compared by
  identity after a ``wake()``, which rclpy's nodes call on every change, and every
  ``COOL_CHECK`` seconds) and kept otherwise. It keeps every handle entered (in use): rclpy
  defers the destruction of an entity destroyed meanwhile until the plan lets go of it, which
  happens on the wake-up that the destroying node sends its executor, so no wait ever sees a
  freed handle;
- a wake-up only clears the wait set and adds the handles of the entities that may run now (no
  handler pending, callback group free), like rclpy's ``can_execute``;
- an entity not ready for ``COOL_AFTER`` seconds (timers and guard conditions excepted) leaves
  this wait for pyconnect.ros.cold_waiter's thread, which hands it back when it is ready again:
  a wake-up then costs what the active entities cost, not what all of them do;
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

import threading
import time
from collections.abc import Callable, Generator
from typing import Any

from rclpy.executors import (
    ConditionReachedException,
    ExternalShutdownException,
    ShutdownException,
    TimeoutException,
)
from rclpy.guard_condition import GuardCondition
from rclpy.node import Node

from pyconnect.ros.cold_waiter import ColdWaiter
from pyconnect.ros.wait_entries import WaitEntry, WaitPlan

COOL_AFTER = 2.0
"""Seconds an entity may stay unready before the cold waiter's thread waits on it instead."""

COOL_CHECK = 0.5
"""Seconds between looks for entities to cool (and a full check of the nodes' entity lists)."""

Ready = tuple[Any, Any, Node]


class PlannedWaits:
    """An executor's wait with a kept plan; ``ready_callbacks`` is its
    ``_wait_for_ready_callbacks``. ``close()`` lets go of every handle (after spinning ends)."""

    def __init__(self, executor: Any, *, cool_after: float = COOL_AFTER) -> None:
        self._executor = executor
        self._cool_after = cool_after
        self._check_every = min(COOL_CHECK, cool_after / 2)
        self._lock = threading.Lock()
        self._plan: WaitPlan | None = None
        self._closed = False
        self._changes = 0
        self._checked = -1
        self._cold = ColdWaiter(executor.context, executor.wake)
        self.plans = 0
        """Plans built so far (tests and diagnostics)."""
        self.waits = 0
        """Waits on the plan's wait set so far (tests and diagnostics)."""

    @property
    def cold_wakes(self) -> int:
        """Wake-ups of the cold waiter's thread so far (tests and diagnostics)."""
        return self._cold.wakes

    @property
    def cold(self) -> int:
        """Entities the cold waiter's thread waits on now (tests and diagnostics)."""
        return self._cold.watching

    def is_cold(self, entity: Any) -> bool:
        """True if the cold waiter's thread waits on ``entity`` now (tests and diagnostics)."""
        return self._cold.has(entity)

    def may_have_changed(self) -> None:
        """The nodes' entities may have changed (rclpy's nodes call ``wake()`` on a change)."""
        self._changes += 1

    def close(self) -> None:
        """Stop the cold waiter and release the plan's handles (waits for a running wait)."""
        self._cold.stop()
        with self._lock:
            self._closed = True
            if self._plan is not None:
                self._plan.release()
                self._plan = None

    def join(self, timeout_sec: float | None = None) -> None:
        self._cold.join(timeout_sec)

    def _current_plan(self, nodes: list[Node], now: float) -> WaitPlan:
        plan = self._plan
        changes = self._changes
        if plan is not None and changes == self._checked and now < plan.next_check:
            return plan
        self._checked = changes
        if plan is None or not plan.is_current(nodes):
            last_ready: dict[Any, float] = {}
            if plan is not None:
                last_ready = {entry.entity: entry.last_ready for entry in plan.entries}
                plan.release()
            self._plan = None
            plan = WaitPlan(nodes, self._executor, last_ready)
            self._plan = plan
            self.plans += 1
            self._cold.watch(plan.cold())
        if now >= plan.next_check:
            plan.next_check = now + self._check_every
            if plan.cool_down(now, self._cool_after):
                self._cold.watch(plan.cold())
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
            with self._lock:
                if self._closed:
                    guard.waiting = False
                    raise ShutdownException()
                nodes_to_use = executor.get_nodes() if nodes is None else list(nodes)
                plan = self._current_plan(nodes_to_use, time.monotonic())
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
            with self._lock:
                if self._closed or self._plan is not plan:
                    continue
                ready = self._wait(plan, deadline, guard)
            takes = {
                "waitable": executor._take_waitable,
                "timer": executor._take_timer,
                "subscription": executor._take_subscription,
                "guard": executor._take_guard_condition,
                "client": executor._take_client,
                "service": executor._take_service,
            }
            for entry in ready:
                entity = entry.entity
                if entry.kind == "timer" and not _timer_ready(entity):
                    # rcl reports cancelled timers as ready.
                    continue
                if entity.callback_group.can_execute(entity):
                    handler = executor._make_handler(entity, entry.node, takes[entry.kind])
                    yielded = True
                    yield handler, entity, entry.node
            if deadline is not None and time.monotonic() >= deadline:
                raise TimeoutException()
        if executor._is_shutdown:
            raise ShutdownException()
        if condition():
            raise ConditionReachedException()

    def _wait(self, plan: WaitPlan, deadline: float | None, guard: WakeGuard) -> list[WaitEntry]:
        """One wait on the plan's usable hot entities; the entries ready, in rclpy's order."""
        executor = self._executor
        warmed = self._cold.take_ready()
        if warmed:
            plan.warm_up(warmed, time.monotonic())
            self._cold.watch(plan.cold())
        wait_set = plan.wait_set
        wait_set.clear_entities()
        adders = {
            "timer": wait_set.add_timer,
            "subscription": wait_set.add_subscription,
            "guard": wait_set.add_guard_condition,
            "client": wait_set.add_client,
            "service": wait_set.add_service,
        }
        guards: list[WaitEntry] = []
        waitables: list[WaitEntry] = []
        for group in (plan.always, plan.hot):
            for entry in group:
                if not entry.usable():
                    continue
                if entry.kind == "waitable":
                    entry.entity.add_to_wait_set(wait_set)
                    waitables.append(entry)
                    continue
                if entry.kind == "guard":
                    if entry.entity._executor_triggered:
                        # Retrigger a guard condition that was triggered but not handled.
                        entry.entity.trigger()
                    guards.append(entry)
                adders[entry.kind](entry.handle)
        for handle in plan.own_guards:
            wait_set.add_guard_condition(handle)
        # While some entities are hot, wake up to cool them even if nothing else happens.
        wake_at = plan.next_check if plan.hot else None
        if deadline is not None and (wake_at is None or deadline < wake_at):
            wake_at = deadline
        if wake_at is None:
            timeout_nsec = -1
        else:
            timeout_nsec = max(0, int((wake_at - time.monotonic()) * 1e9))
        self.waits += 1
        try:
            wait_set.wait(timeout_nsec)
        finally:
            guard.waiting = False
        if executor._is_shutdown:
            raise ShutdownException()
        if not executor.context.ok():
            raise ExternalShutdownException()
        ready: list[WaitEntry] = []
        guards_ready = wait_set.get_ready_entities("guard_condition")
        for entry in guards:
            if entry.pointer in guards_ready:
                entry.entity._executor_triggered = True
        ready.extend(entry for entry in waitables if entry.entity.is_ready(wait_set))
        for kind in ("timer", "subscription", "guard", "client", "service"):
            if kind == "guard":
                ready.extend(entry for entry in guards if entry.entity._executor_triggered)
                continue
            by_pointer = plan.by_pointer[kind]
            ready.extend(
                by_pointer[pointer]
                for pointer in wait_set.get_ready_entities(kind)
                if pointer in by_pointer
            )
        now = time.monotonic()
        for entry in ready:
            entry.last_ready = now
        return ready


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
