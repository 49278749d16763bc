"""How a ``CustomNode`` shuts down: once, from any thread, every step attempted (a mixin).

``shutdown()`` runs ``stop_func`` while the agents still work, then refuses new entities, stops
the executor and the coroutine loop, joins their threads, closes the agents, destroys the node
and leaves the rclpy context; a step that fails is logged and the next ones still run, so a node
is never left half shut down. Called in one of the node's own callbacks (or an ``async def``
handler on pyconnect's loop), it cannot wait for that callback, nor destroy the node under it:
it starts the shutdown on a thread of its own and returns.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call"

from __future__ import annotations

import asyncio
import sys
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from pyconnect.ros.shared_context import leave_context
from pyconnect.ros.shutdown import ShutdownHooks, ShutsDownOnExit

if TYPE_CHECKING:
    from rclpy.context import Context
    from rclpy.node import Node

    from pyconnect.ros.agent_executor import AgentExecutor
    from pyconnect.ros.coroutines import CoroutineRunner
    from pyconnect.ros.node_agent import NodeAgent
    from pyconnect.ros.recording import Recording

JOIN_TIMEOUT = 10.0
"""Seconds shutdown waits for the spin thread, then for each executor thread, to end: a
callback still running after that is left behind (an action goal is aborted, its client told)."""


class NodeShutdown(ShutsDownOnExit):
    """``shutdown()`` and its steps; the node sets these members and destroys its rclpy node."""

    name: str
    context: Context
    stop_func: Callable[..., Any] | None
    agents: dict[str, NodeAgent]
    coroutines: CoroutineRunner
    _lock: threading.RLock
    _closing: bool
    _stopped: threading.Event
    _stopping: threading.Event
    _shutdown_lock: threading.Lock
    _shutting_down_in: int | None
    _spin_thread: threading.Thread | None
    _executor: AgentExecutor
    _hooks: ShutdownHooks
    _recordings: list[Recording]

    # Given by the node's other classes (a stub here would hide rclpy's Node methods in the
    # MRO): declared for the type checker only.
    if TYPE_CHECKING:

        @property
        def ros_node(self) -> Node: ...  # the node itself

        def stop_log_subs(self, timeout: float | None = 10.0) -> None: ...  # NodeLogging

        def _destroy_ros_node(self) -> None: ...  # rclpy's Node.destroy_node, on the node

        def get_logger(self) -> Any: ...  # rclpy's Node.get_logger

    def shutdown(self) -> None:
        """Stop everything once: ``stop_func``, executor, threads, node, rclpy (if ours).

        Called from one of this node's callback threads (a handler, or an ``async def``
        handler on pyconnect's loop), it starts the shutdown on a thread of its own and
        returns at once: the shutdown waits for the callback to end (a service still sends its
        reply), and ``spin()``/``wait_for_shutdown()`` return when everything is closed.
        Called from any other thread, it returns when the node is shut down.
        """
        if self._on_own_thread():
            self._shutdown_after_this_callback()
            return
        if self._shutting_down_in == threading.get_ident():
            return  # stop_func asked again, on the thread already shutting down: it deadlocked
        with self._shutdown_lock:
            if self._stopped.is_set():
                return
            self._shutting_down_in = threading.get_ident()
            try:
                self._shut_down()
            finally:
                self._shutting_down_in = None
                self._stopped.set()

    def _shut_down(self) -> None:
        self._stop_logs_and_recordings()
        if self.stop_func is not None:
            try:
                self.stop_func()
            except Exception as error:
                self._log_error(f"stop_func raised {type(error).__name__}: {error}")
        # After stop_func, which may still use the agents, add one, record: from here nothing
        # new is made (add_agent, record, start_log_subs refuse), and what stop_func started
        # stops too.
        with self._lock:
            self._closing = True
        self._stopping.set()
        self._stop_logs_and_recordings()
        self._attempt("stopping the executor", self._executor.stop)
        # Cancelled coroutines release callbacks that wait for them.
        self._attempt("stopping the coroutine loop", self.coroutines.stop)
        spin_thread = self._spin_thread
        if spin_thread is not None and spin_thread is not threading.current_thread():
            self._attempt("joining the spin thread", lambda: spin_thread.join(JOIN_TIMEOUT))
        self._attempt("joining the executor's threads", lambda: self._executor.join(JOIN_TIMEOUT))
        for agent in list(self.agents.values()):
            self._attempt(f"{agent.describe}: close", agent.close)
        self._attempt(
            "removing the node from its executor", lambda: self._executor.remove_node(self.ros_node)
        )
        self._attempt("destroying the node", self._destroy_ros_node)
        self._attempt(
            "shutting the executor down", lambda: self._executor.shutdown(timeout_sec=1.0)
        )
        self._attempt("leaving the rclpy context", lambda: leave_context(self.context))
        self._attempt("restoring the signal handlers", self._hooks.restore)

    def _stop_logs_and_recordings(self) -> None:
        self._attempt("stop_log_subs", self.stop_log_subs)
        for recording in list(self._recordings):
            self._attempt(f"stopping the recording {str(recording.path)!r}", recording.stop)

    def _on_own_thread(self) -> bool:
        """Whether this thread runs this node's callbacks (its executor's, its coroutine loop):
        a shutdown here would wait for, or destroy the node under, the callback it runs.
        Another node's callback thread is not: shutting this node down there waits, as
        anywhere else."""
        return self._executor.runs_callbacks_here() or self.coroutines.on_own_loop_thread()

    def _shutdown_after_this_callback(self) -> None:
        """Start the shutdown on a thread of its own, once the calling callback can end."""
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:  # an executor thread: the shutdown waits for its callback
            self._shutdown_in_background()
            return
        # An ``async def`` handler on pyconnect's loop: the shutdown cancels what still runs
        # there, so it starts two turns of the loop later, when the handler has returned and
        # its result reached the callback waiting for it (a service's reply is then sent).
        loop.call_soon(loop.call_soon, self._shutdown_in_background)

    def _attempt(self, what: str, step: Callable[[], object]) -> None:
        """Run one shutdown step; a failure is logged and the next steps still run."""
        try:
            step()
        except Exception as error:
            self._log_error(f"shutdown: {what} failed: {type(error).__name__}: {error}")

    def destroy_node(self) -> None:
        """rclpy's name for ``shutdown()`` (stops the agents first, then destroys the node)."""
        self.shutdown()

    def _log_error(self, text: str) -> None:
        try:
            self.get_logger().error(text)
        except Exception:
            print(f"[pyconnect] {self.name}: {text}", file=sys.stderr)
