"""Ending nodes cleanly on Ctrl-C, SIGTERM and interpreter exit.

Why not rclpy's handlers: on Ctrl-C rclpy shuts the context down under the executor, which
raises ``ExternalShutdownException`` (rclpy#1166) and skips ``on_shutdown`` hooks (rclpy#532);
Python then tears objects down while threads still sit in ``rcl_wait``, which can end in
``terminate called ...``. pyconnect initialises rclpy without signal handlers and installs its
own (main thread only, one pair per process, shared by every ``CustomNode``): the first
SIGINT/SIGTERM starts each node's shutdown on a thread of its own (``stop_func`` once, executor
stopped, threads joined, node destroyed, ``rclpy.try_shutdown``); if the main thread is waiting
in ``spin()``/``wait_for_shutdown()`` it returns normally, otherwise ``SystemExit(0)`` unwinds
the user's code (``finally`` blocks run) and the process exits 0. A second signal raises
``KeyboardInterrupt`` at once. A handler the program installed before the first node (a
Python function, not Python's own ``default_int_handler``) is called after the shutdown has
started, as rclpy chains to it, and decides what the main thread does next instead of the
``SystemExit(0)``: it may return (the program goes on, its nodes shut down) or raise. The
shutdown runs on its own non-daemon thread, so it completes whatever that handler raises.
At interpreter exit an ``atexit`` hook runs the same shutdown
(spin threads are daemons, joined there); a peer's runs as soon as the main thread ends, since
zenoh's callback threads are not daemons and would keep the process waiting for ever. The
previous handlers come back when the last node that installed them is shut down from the main
thread.
"""

from __future__ import annotations

import atexit
import contextlib
import signal
import sys
import threading
from collections.abc import Callable
from types import FrameType, TracebackType
from typing import Any, TypeGuard

_HANDLED_SIGNALS = (signal.SIGINT, signal.SIGTERM)
_lock = threading.Lock()
_live: list[ShutdownHooks] = []
_previous: dict[int, Any] = {}
_state = {"signalled": False, "early_dispatch": False}


def _on_signal(signum: int, frame: FrameType | None) -> None:
    with _lock:
        hooks = list(_live)
        again = _state["signalled"]
        _state["signalled"] = True
    if again or not hooks:
        _restore_handlers()
        raise KeyboardInterrupt
    for hook in hooks:
        hook.begin_shutdown()
    previous = _previous.get(signum)
    if _is_program_handler(previous):
        previous(signum, frame)
    elif not any(hook.main_is_waiting() for hook in hooks):
        raise SystemExit(0)


def _is_program_handler(
    handler: object,
) -> TypeGuard[Callable[[int, FrameType | None], object]]:
    """Whether ``handler`` was installed by the program (not Python's default, ``SIG_DFL``,
    ``SIG_IGN`` or ``None`` for a handler set outside Python)."""
    return callable(handler) and handler is not signal.default_int_handler


def _install_handlers() -> None:
    if _previous or threading.current_thread() is not threading.main_thread():
        return
    for signum in _HANDLED_SIGNALS:
        _previous[signum] = signal.getsignal(signum)
        signal.signal(signum, _on_signal)


def _restore_handlers() -> None:
    if threading.current_thread() is not threading.main_thread():
        return
    for signum, previous in _previous.items():
        if signal.getsignal(signum) is _on_signal:
            signal.signal(signum, previous if previous is not None else signal.SIG_DFL)
    _previous.clear()


class ShutdownHooks:
    """One node's entry in the process-wide signal handlers, and its atexit hook."""

    def __init__(
        self,
        *,
        begin_shutdown: Callable[[], None],
        main_is_waiting: Callable[[], bool],
        handle_signals: bool,
    ) -> None:
        self.begin_shutdown = begin_shutdown
        self.main_is_waiting = main_is_waiting
        self._handles_signals = handle_signals
        self._atexit_hook: Callable[[], None] | None = None
        if handle_signals:
            with _lock:
                _live.append(self)
            _install_handlers()

    def register_atexit(
        self, hook: Callable[[], None], *, before_threads_end: bool = False
    ) -> None:
        """Run ``hook`` at interpreter exit: after the program's other threads have ended, or
        with ``before_threads_end`` as soon as the main thread ends (for a zenoh session, whose
        callback threads never end on their own, so waiting for them first would hang)."""
        self._atexit_hook = hook
        if before_threads_end:
            with _lock:
                _early_hooks.append(hook)
            _register_early_dispatch()
        else:
            atexit.register(hook)

    def restore(self) -> None:
        """Leave the signal handlers (restoring the old ones after the last node) and atexit."""
        hook, self._atexit_hook = self._atexit_hook, None
        if hook is not None:
            atexit.unregister(hook)
            with _lock, contextlib.suppress(ValueError):
                _early_hooks.remove(hook)
        if not self._handles_signals:
            return
        with _lock:
            if self in _live:
                _live.remove(self)
            last = not _live
            if last:  # the next node starts afresh: its first signal is a first one
                _state["signalled"] = False
        if last:
            _restore_handlers()


_early_hooks: list[Callable[[], None]] = []


def _register_early_dispatch() -> None:
    """Once per process: run ``_early_hooks`` when the main thread ends, before Python waits
    for the other non-daemon threads (``threading._register_atexit``, as concurrent.futures
    uses it; plain ``atexit`` where it is missing)."""
    with _lock:
        if _state["early_dispatch"]:
            return
        _state["early_dispatch"] = True
    register = getattr(threading, "_register_atexit", atexit.register)
    register(_run_early_hooks)


def _run_early_hooks() -> None:
    with _lock:
        hooks = list(reversed(_early_hooks))
    for hook in hooks:
        try:
            hook()
        except Exception as error:  # as atexit would, but every hook runs
            print(f"[pyconnect] shutdown at exit failed: {error!r}", file=sys.stderr)


class ShutsDownOnExit:
    """What a node and a peer share: ``shutdown()`` on leaving ``with``, or from a signal.

    The owner sets ``name``, ``_shutdown_thread = None`` and defines ``shutdown()``.
    """

    name: str
    _shutdown_thread: threading.Thread | None

    def shutdown(self) -> None:
        raise NotImplementedError

    def _shutdown_in_background(self) -> None:
        if self._shutdown_thread is not None:
            return
        # Not a daemon: the interpreter waits for it before exiting.
        self._shutdown_thread = threading.Thread(
            target=self.shutdown, name=f"pyconnect-shutdown-{self.name}", daemon=False
        )  # (a thread started from a daemon thread would be a daemon too)
        self._shutdown_thread.start()

    def __enter__(self) -> Any:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.shutdown()
