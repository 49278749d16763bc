"""The ROS graph as a peer sees it: rmw_zenoh's liveliness tokens of one domain, kept current.

rmw_zenoh's ``rmw_context_impl_s.cpp`` subscribes to ``@ros2_lv/<domain>/**`` with history, so
tokens declared before the subscription are reported too; a token disappears (a DELETE
sample) when its entity is destroyed or its session vanishes (zenoh notices a lost peer by
its lease), which is how a peer notices a vanished publisher or server.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Callable
from typing import Any

import zenoh

from pyconnect.transport.rmw_zenoh_keys import ADMIN_SPACE, Token, parse_token


class Graph:
    """Live tokens by key; ``count`` answers "is there a server / publisher now?"."""

    def __init__(self, session: zenoh.Session, domain_id: int) -> None:
        self._tokens: dict[str, Token] = {}
        # Reentrant: conditions given to wait_for_graph ask count() while holding it.
        self._lock = threading.RLock()
        self.changed = threading.Condition(self._lock)
        # (new-token watcher, gone-token watcher or None), in the order they were added
        self._watchers: list[tuple[Callable[[Token], None], Callable[[Token], None] | None]] = []
        self._subscriber: Any = session.liveliness().declare_subscriber(
            f"{ADMIN_SPACE}/{domain_id}/**", self._on_sample, history=True
        )

    def _on_sample(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        with self._lock:
            if sample.kind == zenoh.SampleKind.DELETE:
                gone = self._tokens.pop(key, None)
                if gone is not None:
                    for _watcher, on_gone in self._watchers:
                        if on_gone is not None:
                            on_gone(gone)
            else:
                token = parse_token(key)
                if token is not None and key not in self._tokens:
                    self._tokens[key] = token
                    for watcher, _on_gone in self._watchers:
                        watcher(token)
            self.changed.notify_all()

    def watch(
        self, watcher: Callable[[Token], None], *, gone: Callable[[Token], None] | None = None
    ) -> None:
        """Call ``watcher(token)`` for every token now live and every new one, and
        ``gone(token)`` for every one of them that disappears (on zenoh's thread, under the
        graph's lock: they must return at once)."""
        with self._lock:
            self._watchers.append((watcher, gone))
            for token in self._tokens.values():
                watcher(token)

    def unwatch(self, watcher: Callable[[Token], None]) -> None:
        """Stop calling ``watcher`` and the ``gone`` given with it."""
        with self._lock:
            self._watchers = [pair for pair in self._watchers if pair[0] != watcher]

    def tokens(self) -> list[Token]:
        with self._lock:
            return list(self._tokens.values())

    def count(
        self,
        *,
        kind: str,
        name: str,
        type_name: str | None = None,
        type_hash: str | None = None,
    ) -> int:
        """How many live entities of ``kind`` (``'MP'``, ``'SS'``, ...) are on ``name``, of
        ``type_name`` and ``type_hash`` where given (the others use other keys: they never
        meet an entity of this type)."""
        with self._lock:
            return sum(
                1
                for t in self._tokens.values()
                if t.kind == kind
                and t.name == name
                and (type_name is None or t.type_name == type_name)
                and (type_hash is None or t.type_hash == type_hash)
            )

    def other_types(
        self, *, kind: str, name: str, type_name: str, type_hash: str
    ) -> list[tuple[str, str]]:
        """The (type name, RIHS01 hash) pairs, sorted, of live entities of ``kind`` on
        ``name`` that differ from ``type_name`` with ``type_hash``."""
        with self._lock:
            return sorted(
                {
                    (t.type_name, t.type_hash)
                    for t in self._tokens.values()
                    if t.kind == kind
                    and t.name == name
                    and (t.type_name, t.type_hash) != (type_name, type_hash)
                }
            )

    def node_names(self) -> list[str]:
        with self._lock:
            return sorted(t.node_name for t in self._tokens.values() if t.kind == "NN")

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self._subscriber.undeclare()
