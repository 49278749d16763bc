"""Waiting in user threads for what the executor does: a server to appear, a response to arrive."""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import concurrent.futures
import contextlib
import threading
import time
from collections.abc import Callable
from typing import Any, Protocol


def wait_until(
    ready: Callable[[], bool], timeout: float | None, *, stop: threading.Event | None = None
) -> bool:
    """Poll ``ready`` (a cheap graph query) until it is true; False on timeout or ``stop``.

    rclpy has no event for "a server appeared" (rclpy#58), so this polls like its own
    ``wait_for_service``, but at 20 ms, and ends early when ``stop`` is set.
    """
    deadline = None if timeout is None else time.monotonic() + timeout
    idle = stop or threading.Event()
    while not ready():
        remaining = None if deadline is None else deadline - time.monotonic()
        if remaining is not None and remaining <= 0:
            return False
        if idle.wait(0.02 if remaining is None else min(remaining, 0.02)):
            return False  # stopped: the node may already be destroyed, so ask it nothing
    return True


def running_thread(
    thread: threading.Thread | None, target: Callable[[], None], name: str
) -> threading.Thread:
    """``thread`` when it is alive, else a new daemon thread running ``target``, started."""
    if thread is not None and thread.is_alive():
        return thread
    started = threading.Thread(target=target, name=name, daemon=True)
    started.start()
    return started


def settle(future: concurrent.futures.Future[Any], compute: Callable[[], Any]) -> None:
    """Give ``future`` the value of ``compute()`` (or what it raised), unless the caller gave up
    on it already (an ``await send_async`` that timed out cancels it)."""
    if future.done():
        return
    try:
        value = compute()
    except Exception as error:
        with contextlib.suppress(concurrent.futures.InvalidStateError):
            future.set_exception(error)
        return
    with contextlib.suppress(concurrent.futures.InvalidStateError):
        future.set_result(value)


class EventLike(Protocol):
    """What a wait needs of an event: ``threading.Event`` and ``Signal`` both are one."""

    def is_set(self) -> bool: ...

    def wait(self, timeout: float | None = None) -> bool: ...


class Signal:
    """A one-shot ``threading.Event`` on one bare lock, for a reply that one thread waits for.

    ``threading.Event`` is a ``Condition``: each wait allocates a lock and each ``set`` walks
    the waiters under another; a service round trip pays both on the critical path. Here the
    waiter blocks on a lock that ``set`` releases once. Any number of ``wait`` calls work
    (each gives the lock back); ``set`` twice is harmless.
    """

    __slots__ = ("_lock", "_set")

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._lock.acquire()
        self._set = False

    def set(self) -> None:
        if self._set:
            return
        self._set = True
        with contextlib.suppress(RuntimeError):  # a racing second set() released it already
            self._lock.release()

    def is_set(self) -> bool:
        return self._set

    def wait(self, timeout: float | None = None) -> bool:
        if self._set:
            return True
        if self._lock.acquire(True, -1 if timeout is None else max(0.0, timeout)):
            with contextlib.suppress(RuntimeError):
                self._lock.release()
        return self._set
