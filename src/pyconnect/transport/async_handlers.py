"""``async def`` handlers of a peer's agents, run to completion on the agent's own thread.

A handler is called as a plain function; when it returns a coroutine, ``settle`` runs that
coroutine here, on the calling thread, and its return value is the handler's result (what a
service answers, what ``get()`` of a timer gives). An exception inside it propagates to the
caller like any handler's, so the agent reports it as it reports any other. Running it on the
agent's thread keeps CustomNode's order: one agent's coroutines run one after another, in
arrival order, and a slow one holds up its own agent only.

Each agent thread runs its body inside ``agent_loop()``: the thread's first coroutine creates
an event loop that serves all its later ones (a new loop per call would cost a selector and a
socket pair each time) and the loop is closed when the body ends. On a thread without that
scope (e.g. an action client's ``response_func`` on the caller's thread) a coroutine gets a
loop of its own, as ``asyncio.run`` gives it.

A peer's shutdown cancels the coroutine an agent thread is running (``cancel_coroutine``), as a
``CustomNode`` cancels its handlers' tasks: the handler's ``finally`` blocks run, and its agent
closes at once instead of waiting out its join timeout. Not the one that asked for the shutdown
(``spare_coroutine``): a "stop" service still sends its reply.
"""

from __future__ import annotations

import asyncio
import contextlib
import inspect
import threading
import weakref
from collections.abc import Coroutine, Iterator
from typing import Any

_local = threading.local()
_running: dict[threading.Thread, asyncio.Task[Any]] = {}
_running_lock = threading.Lock()
_spared: weakref.WeakSet[threading.Thread] = weakref.WeakSet()


@contextlib.contextmanager
def agent_loop() -> Iterator[None]:
    """Scope of an agent thread's body: its coroutines share one loop, closed at the end."""
    if getattr(_local, "scoped", False):  # nested: the outer scope owns the loop
        yield
        return
    _local.scoped = True
    try:
        yield
    finally:
        _local.scoped = False
        loop: asyncio.AbstractEventLoop | None = getattr(_local, "loop", None)
        _local.loop = None
        if loop is not None:
            _close(loop)


def settle(outcome: Any) -> Any:
    """``outcome``, or when it is a coroutine (an ``async def`` handler's), what it returns."""
    if not inspect.iscoroutine(outcome):
        return outcome
    return run_coroutine(outcome)


def run_coroutine(coroutine: Coroutine[Any, Any, Any]) -> Any:
    """Run ``coroutine`` to completion on this thread's loop; its result or its exception."""
    loop = thread_loop()
    if loop is None:
        return asyncio.run(coroutine)
    task = loop.create_task(coroutine)
    thread = threading.current_thread()
    with _running_lock:
        _running[thread] = task
    try:
        return loop.run_until_complete(task)
    finally:
        with _running_lock:
            _running.pop(thread, None)


def spare_coroutine(thread: threading.Thread) -> None:
    """Leave the coroutine ``thread`` runs to finish: its handler asked for the shutdown."""
    with _running_lock:
        _spared.add(thread)


def cancel_coroutine(thread: threading.Thread | None) -> None:
    """Cancel the coroutine ``thread`` runs in ``run_coroutine`` now, if any: it raises
    ``CancelledError`` there, in the handler's caller."""
    if thread is None:
        return
    with _running_lock:
        task = None if thread in _spared else _running.get(thread)
    if task is None:
        return
    with contextlib.suppress(RuntimeError):  # it ended and its loop closed meanwhile
        task.get_loop().call_soon_threadsafe(task.cancel)


def thread_loop() -> asyncio.AbstractEventLoop | None:
    """This agent thread's loop (made on first use); None outside ``agent_loop()``."""
    if not getattr(_local, "scoped", False):
        return None
    loop: asyncio.AbstractEventLoop | None = getattr(_local, "loop", None)
    if loop is None:
        loop = _local.loop = asyncio.new_event_loop()
    return loop


def _close(loop: asyncio.AbstractEventLoop) -> None:
    """What ``asyncio.run`` does at its end: cancel leftover tasks, finish async generators."""
    try:
        tasks = asyncio.all_tasks(loop)
        for task in tasks:
            task.cancel()
        if tasks:
            loop.run_until_complete(asyncio.gather(*tasks, return_exceptions=True))
        loop.run_until_complete(loop.shutdown_asyncgens())
        loop.run_until_complete(loop.shutdown_default_executor())
    finally:
        loop.close()
