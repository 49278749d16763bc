"""The ElasticExecutor's second wait: a thread waiting on the entities that have been quiet.

A wait costs CPU for every entity in its wait set, in Python (adding each) and in the middleware
(attaching a condition to each and checking it), on every wake-up. In a node with 120 agents
nearly all of them are quiet while a few timers tick. So pyconnect.ros.wait_plan moves an
entity that has not been ready for ``COOL_AFTER`` seconds here: this thread waits on all such
entities at once, only wakes when one of them becomes ready (or the set changes), and hands it
back to the executor's own wait (``take_ready``), which then finds it ready as well (messages,
requests and events stay ready until taken) and runs its callback. The cost of a quiet entity
becoming active is one wake-up of this thread.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import contextlib
import threading
from collections.abc import Callable
from typing import Any

from rclpy.guard_condition import GuardCondition
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.waitable import NumberOfEntities


class ColdWaiter:
    """A thread waiting on ``watch``-ed entities; wakes the executor when one is ready.

    An entry (pyconnect.ros.wait_plan's) has ``kind`` (``'subscription'``, ``'client'``,
    ``'service'`` or ``'waitable'``), ``entity``, ``handle``, ``pointer`` and ``counts`` (its
    ``NumberOfEntities``).
    """

    def __init__(self, context: Any, wake: Callable[[], None]) -> None:
        self._context = context
        self._wake = wake
        self._lock = threading.Lock()
        self._members: dict[Any, None] = {}
        self._found: list[Any] = []
        self._guard: GuardCondition | None = None
        self._stopped = False
        self._thread: threading.Thread | None = None
        self.wakes = 0
        """Wake-ups of this thread so far (tests and diagnostics)."""
        with contextlib.suppress(Exception):
            context.on_shutdown(self.stop)

    @property
    def watching(self) -> int:
        """How many entries this thread waits on now."""
        return len(self._members)

    def has(self, entity: Any) -> bool:
        """True if this thread waits on ``entity`` now."""
        with self._lock:
            return any(entry.entity is entity for entry in self._members)

    def watch(self, entries: list[Any]) -> None:
        """Wait on ``entries`` from now on (the thread starts on the first non-empty list)."""
        with self._lock:
            if self._stopped:
                return
            found = set(self._found)
            members = {entry: None for entry in entries if entry not in found}
            if list(members) == list(self._members):
                return
            self._members = members
            if self._thread is None and members:
                self._guard = GuardCondition(None, None, context=self._context)
                self._thread = threading.Thread(
                    target=self._run, name="pyconnect-executor-cold", daemon=True
                )
                self._thread.start()
        self._trigger()

    def take_ready(self) -> list[Any]:
        """The entries found ready since the last call (no longer waited on here)."""
        if not self._found:
            return []
        with self._lock:
            found, self._found = self._found, []
        return found

    def stop(self) -> None:
        with self._lock:
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
                with self._lock:
                    if self._stopped:
                        return
                    waiting = list(self._members)
                ready = self._wait(guard, waiting)
                self.wakes += 1
                if not self._context.ok():
                    return
                if ready:
                    with self._lock:
                        for entry in ready:
                            if self._members.pop(entry, False) is None:
                                self._found.append(entry)
                    with contextlib.suppress(Exception):
                        self._wake()
        except Exception:  # the context went away under us: nothing left to watch
            return
        finally:
            with contextlib.suppress(Exception):
                guard.destroy()

    def _wait(self, guard: GuardCondition, waiting: list[Any]) -> list[Any]:
        """One wait on ``waiting`` (handles entered for its duration); the entries ready."""
        with contextlib.ExitStack() as stack:
            stack.enter_context(guard.handle)
            entered: list[Any] = []
            count = NumberOfEntities()
            for entry in waiting:
                try:
                    stack.enter_context(entry.entity if entry.kind == "waitable" else entry.handle)
                except Exception:  # InvalidHandle: destroyed meanwhile
                    continue
                entered.append(entry)
                count += entry.counts
            stack.enter_context(self._context.handle)
            wait_set = _rclpy.WaitSet(
                count.num_subscriptions,
                count.num_guard_conditions + 1,
                count.num_timers,
                count.num_clients,
                count.num_services,
                count.num_events,
                self._context.handle,
            )
            wait_set.clear_entities()
            wait_set.add_guard_condition(guard.handle)
            adders = {
                "subscription": wait_set.add_subscription,
                "client": wait_set.add_client,
                "service": wait_set.add_service,
            }
            for entry in entered:
                if entry.kind == "waitable":
                    entry.entity.add_to_wait_set(wait_set)
                else:
                    adders[entry.kind](entry.handle)
            wait_set.wait(-1)
            pointers = {
                kind: set(wait_set.get_ready_entities(kind))
                for kind in ("subscription", "client", "service")
            }
            return [
                entry
                for entry in entered
                if (
                    entry.entity.is_ready(wait_set)
                    if entry.kind == "waitable"
                    else entry.pointer in pointers[entry.kind]
                )
            ]
