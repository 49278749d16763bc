"""A peer sub's watch on publishers of other types on its topic: listen on their keys while
they live, so their samples are counted instead of silently missed.

Publishers of another type (or of another version of the type: a different RIHS01 hash) show
up in the graph with their tokens. For each such key the sub also listens there, while a
publisher token names the key, and on at most ``MAX_OTHER_TYPES`` keys at once: each costs a
zenoh subscriber and the thread zenoh-python runs its callback on (300 bogus tokens once left
300 threads for good); more are reported once, not listened to. A key that meets the sub's own
(a wildcard in a token) is never listened on: its good samples would be counted as bad ones.
"""

# zenoh's stubs leave undeclare() unannotated.
# mypy: disable-error-code="no-untyped-call"

from __future__ import annotations

import contextlib
import logging
import threading
from collections.abc import Callable
from typing import Any

import zenoh

from pyconnect.transport import rmw_zenoh_keys as keys

__all__ = ["MAX_OTHER_TYPES", "OtherTypeKeys"]

MAX_OTHER_TYPES = 64
"""Keys of other types listened to at once: a few in practice; the bound keeps a flood of bogus
tokens from costing a thread each."""

logger = logging.getLogger("pyconnect.transport")

OnSample = Callable[[zenoh.Sample, str], None]
"""Called on zenoh's thread with a sample of another type and the text reporting it."""


class OtherTypeKeys:
    """The keys of other types a sub listens on, following the graph's publisher tokens."""

    def __init__(
        self,
        session: Any,
        *,
        domain_id: int,
        topic: str,
        own_key: str,
        type_name: str,
        type_hash: str,
        describe: str,
        thread_name: str,
        on_sample: OnSample,
    ) -> None:
        self._session = session
        self._domain_id = domain_id
        self._topic = topic
        self._own_key = zenoh.KeyExpr(own_key)
        self._type_name = type_name
        self._type_hash = type_hash
        self._describe = describe
        self._thread_name = thread_name
        self._on_sample = on_sample
        self.listened: dict[str, Any] = {}
        """Keys listened to: their subscriber (None while being declared)."""
        self.publishers: dict[str, tuple[str, set[str]]] = {}
        """Per key with a live publisher token: the report for its samples and the keys of
        those tokens."""
        self._lock = threading.Lock()
        self.worker: threading.Thread | None = None
        """The thread declaring and undeclaring subscribers, while it has work."""
        self._warned = False
        self._closed = False

    def key_of(self, token: keys.Token) -> str | None:
        """The data key of ``token``'s publisher when it is one of another type on the topic."""
        if token.kind != keys.PUBLISHER or token.name != self._topic:
            return None
        if token.type_hash == self._type_hash and token.type_name == self._type_name:
            return None
        try:
            key = keys.data_key(self._domain_id, self._topic, token.type_name, token.type_hash)
            if zenoh.KeyExpr(key).intersects(self._own_key):
                return None
        except Exception:
            return None  # a type name that maps to no key: nothing of it can reach us
        return key

    def on_token(self, token: keys.Token) -> None:
        """A new token (zenoh's thread): listen on the key of a publisher of another type."""
        key = self.key_of(token)
        if key is None or self._closed:
            return
        with self._lock:
            entry = self.publishers.get(key)
            if entry is None:
                text = (
                    f"ignored samples of {token.type_name} ({token.type_hash}); this "
                    f"subscription expects {self._type_name} ({self._type_hash})"
                )
                entry = self.publishers[key] = (text, set())
            entry[1].add(token.key)
            over = len(self.publishers) > MAX_OTHER_TYPES and not self._warned
            self._warned |= over
        if over:
            logger.warning(
                "%s on %s: publishers of more than %d other types; samples of the types beyond "
                "those are not listened to (not counted in type_mismatch_count)",
                self._describe,
                self._topic,
                MAX_OTHER_TYPES,
            )
        self._update()

    def on_token_gone(self, token: keys.Token) -> None:
        """A token gone (zenoh's thread): stop listening on a key no publisher uses any more."""
        key = self.key_of(token)
        if key is None:
            return
        with self._lock:
            entry = self.publishers.get(key)
            if entry is None:
                return
            entry[1].discard(token.key)
            if entry[1]:
                return
            del self.publishers[key]
        self._update()

    def close(self, timeout: float) -> None:
        """Undeclare every subscriber (waiting up to ``timeout`` s for the worker)."""
        self._closed = True  # no key is wanted: the worker undeclares them all
        self._update()
        with self._lock:
            worker = self.worker
        if worker is not None and worker is not threading.current_thread():
            worker.join(timeout)

    def _update(self) -> None:
        """Have the keys listened to follow the live publishers, off zenoh's thread (which is
        delivering a token): one worker at a time, ending once nothing is left to do."""
        with self._lock:
            if self.worker is not None:
                return  # it looks again before it ends
            self.worker = threading.Thread(target=self._follow, name=self._thread_name)
            self.worker.daemon = True
            self.worker.start()

    def _wanted(self) -> list[str]:
        """Keys to listen on (under the lock): those listened to that still have a publisher,
        then the others in the order they came, up to ``MAX_OTHER_TYPES``."""
        if self._closed:
            return []
        live = self.publishers
        kept = [key for key in self.listened if key in live]
        room = MAX_OTHER_TYPES - len(kept)
        return kept + [key for key in live if key not in self.listened][: max(room, 0)]

    def _follow(self) -> None:
        while True:
            with self._lock:
                wanted = self._wanted()
                stale = [key for key in self.listened if key not in wanted]
                new = [key for key in wanted if key not in self.listened]
                if not stale and not new:
                    self.worker = None
                    return
                entities = [self.listened.pop(key) for key in stale]
                for key in new:
                    self.listened[key] = None
                texts = {key: self.publishers[key][0] for key in new}
            for entity in entities:
                with contextlib.suppress(Exception):
                    entity.undeclare()
            for key in new:
                subscriber = None
                with contextlib.suppress(Exception):
                    subscriber = self._session.declare_subscriber(key, self._counter(texts[key]))
                with self._lock:
                    self.listened[key] = subscriber

    def _counter(self, text: str) -> Callable[[zenoh.Sample], None]:
        def on_sample(sample: zenoh.Sample) -> None:
            self._on_sample(sample, text)

        return on_sample
