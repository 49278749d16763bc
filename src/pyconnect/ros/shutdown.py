"""Ending a node cleanly on Ctrl-C, SIGTERM and interpreter exit.

Why not rclpy's handlers: on Ctrl-C rclpy shuts the context down under the executor, which
raises ``ExternalShutdownException`` (rclpy#1166) and skips ``on_shutdown`` hooks (rclpy#532);
Python then tears objects down while threads still sit in ``rcl_wait``, which can end in
``terminate called ...``. pyconnect initialises rclpy without signal handlers and installs its
own (main thread only): the first SIGINT/SIGTERM starts the node's shutdown on a thread of its
own (``stop_func`` once, executor stopped, threads joined, node destroyed,
``rclpy.try_shutdown``); if the main thread is waiting in ``spin()``/``wait_for_shutdown()`` it
returns normally, otherwise ``SystemExit(0)`` unwinds the user's code (``finally`` blocks run)
and the process exits 0. A second signal raises ``KeyboardInterrupt`` at once. At interpreter
exit an ``atexit`` hook runs the same shutdown (spin threads are daemons, joined there).
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import atexit
import signal
import threading
from collections.abc import Callable
from types import FrameType
from typing import Any

_HANDLED_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class ShutdownHooks:
    """Signal handlers and an atexit hook that call ``begin_shutdown`` for one node."""

    def __init__(
        self,
        *,
        begin_shutdown: Callable[[], None],
        main_is_waiting: Callable[[], bool],
        handle_signals: bool,
    ) -> None:
        self._begin_shutdown = begin_shutdown
        self._main_is_waiting = main_is_waiting
        self._signalled = False
        self._previous: dict[int, Any] = {}
        self._atexit_hook: Callable[[], None] | None = None
        if handle_signals and threading.current_thread() is threading.main_thread():
            for signum in _HANDLED_SIGNALS:
                self._previous[signum] = signal.getsignal(signum)
                signal.signal(signum, self._on_signal)

    def register_atexit(self, hook: Callable[[], None]) -> None:
        self._atexit_hook = hook
        atexit.register(hook)

    def _on_signal(self, signum: int, frame: FrameType | None) -> None:
        if self._signalled:
            self.restore()
            raise KeyboardInterrupt
        self._signalled = True
        self._begin_shutdown()
        if not self._main_is_waiting():
            raise SystemExit(0)

    def restore(self) -> None:
        """Put back the signal handlers that were there before (from the main thread only)."""
        if self._atexit_hook is not None:
            atexit.unregister(self._atexit_hook)
            self._atexit_hook = None
        if threading.current_thread() is not threading.main_thread():
            return
        for signum, previous in self._previous.items():
            if signal.getsignal(signum) == self._on_signal:
                signal.signal(signum, previous if previous is not None else signal.SIG_DFL)
        self._previous.clear()
