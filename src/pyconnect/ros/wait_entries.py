"""The ElasticExecutor's wait plan: the entities of its nodes, handles held, one wait set.

pyconnect.ros.wait_plan builds a ``WaitPlan`` when the nodes' entity lists change and keeps it
between wake-ups (why: its docstring). An entity's ``WaitEntry`` says how it waits (its kind,
handle, pointer and counts), whether its callback group lets it run now (as rclpy's
``can_execute``), and whether it is hot (in the executor's wait) or cold (left to
pyconnect.ros.cold_waiter's thread).
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import contextlib
import time
from typing import Any

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.waitable import NumberOfEntities

_FREE, _EXCLUSIVE, _ASK = 0, 1, 2
"""How a callback group says whether its entity may run: always, while no callback of the
group runs (read without its lock: a stale answer costs one spare wake-up, the handler asks
again), or by calling its ``can_execute``."""


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


class WaitEntry:
    """One entity of the plan: its handle (entered), callback group, node, and how it waits."""

    __slots__ = (
        "counts",
        "entity",
        "group",
        "handle",
        "hot",
        "kind",
        "last_ready",
        "mode",
        "node",
        "pointer",
    )

    def __init__(self, kind: str, entity: Any, node: Node, last_ready: float) -> None:
        self.kind = kind
        self.entity = entity
        self.handle = None if kind == "waitable" else entity.handle
        self.pointer = 0 if self.handle is None else self.handle.pointer
        self.counts = entity.get_num_entities() if kind == "waitable" else _ONE[kind]
        self.group = entity.callback_group
        self.mode = _group_kind(self.group)
        self.node = node
        self.hot = True
        self.last_ready = last_ready

    def usable(self) -> bool:
        if self.entity._executor_event:
            return False
        if self.mode == _EXCLUSIVE:
            return self.group._active_entity is None
        return self.mode == _FREE or bool(self.group.can_execute(self.entity))


_ONE = {
    "subscription": NumberOfEntities(num_subs=1),
    "client": NumberOfEntities(num_clients=1),
    "service": NumberOfEntities(num_services=1),
    "timer": NumberOfEntities(num_timers=1),
    "guard": NumberOfEntities(num_gcs=1),
}


class WaitPlan:
    """The entities of some nodes, their handles entered, and a wait set sized for all."""

    def __init__(self, nodes: list[Node], executor: Any, last_ready: dict[Any, float]) -> None:
        self.nodes = nodes
        self.lists = [_node_lists(node) for node in nodes]
        self.stack = contextlib.ExitStack()
        self.entries: list[WaitEntry] = []
        now = time.monotonic()
        count = NumberOfEntities()
        try:
            for node, (subs, timers, clients, services, guards, waitables) in zip(
                nodes, self.lists, strict=True
            ):
                for kind, entities in (
                    ("timer", timers),
                    ("subscription", subs),
                    ("guard", guards),
                    ("client", clients),
                    ("service", services),
                    ("waitable", waitables),
                ):
                    for entity in entities:
                        if self._enter(entity if kind == "waitable" else entity.handle):
                            entry = WaitEntry(kind, entity, node, last_ready.get(entity, now))
                            self.entries.append(entry)
                            count += entry.counts
            self.own_guards = [executor._guard.handle, executor._sigint_gc.handle]
            for handle in self.own_guards:
                self.stack.enter_context(handle)
            context = executor.context.handle
            self.stack.enter_context(context)
            self.wait_set = _rclpy.WaitSet(
                count.num_subscriptions,
                count.num_guard_conditions + len(self.own_guards),
                count.num_timers,
                count.num_clients,
                count.num_services,
                count.num_events,
                context,
            )
        except BaseException:
            self.stack.close()
            raise
        # Timers and guard conditions always wait here: a timer's next tick is due anyway.
        self.always = [entry for entry in self.entries if entry.kind in ("timer", "guard")]
        self.hot = [entry for entry in self.entries if entry.kind not in ("timer", "guard")]
        self.by_pointer: dict[str, dict[int, WaitEntry]] = {
            kind: {entry.pointer: entry for entry in self.entries if entry.kind == kind}
            for kind in ("subscription", "timer", "client", "service")
        }
        self.next_check = now

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

    def cold(self) -> list[WaitEntry]:
        return [entry for entry in self.entries if not entry.hot and entry.kind != "timer"]

    def warm_up(self, entries: list[WaitEntry], now: float) -> None:
        """``entries`` (found ready by the cold waiter) wait here again."""
        for entry in entries:
            if not entry.hot:
                entry.hot = True
                entry.last_ready = now
                self.hot.append(entry)

    def cool_down(self, now: float, cool_after: float) -> bool:
        """Leave entities unready for ``cool_after`` s to the cold waiter; True if any left."""
        keep = [
            entry
            for entry in self.hot
            if now - entry.last_ready < cool_after or entry.entity._executor_event
        ]
        if len(keep) == len(self.hot):
            return False
        for entry in self.hot:
            entry.hot = False
        for entry in keep:
            entry.hot = True
        self.hot = keep
        return True

    def release(self) -> None:
        self.stack.close()
