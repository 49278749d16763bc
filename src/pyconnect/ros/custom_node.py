"""``CustomNode``: one ROS node holding a robot program's agents, with one API to run and stop it.

A ``CustomNode`` *is* an ``rclpy.node.Node`` (parameters, clock, ``get_logger``, ``create_*``
all work on it, as the design promises); it also owns an ``AgentExecutor``
(pyconnect.ros.agent_executor), a coroutine runner for ``async def`` handlers
(pyconnect.ros.coroutines) and the agents made by ``add_agent``. ``spin(run_thread=True)``
spins in a daemon thread; ``spin()`` (or ``listen()``) blocks until shutdown. Shutdown —
``shutdown()``, leaving ``with``, Ctrl-C, SIGTERM or interpreter exit — runs ``stop_func`` once
while the agents still work, stops the executor, joins its threads, destroys the node and, for
the last node on a context pyconnect initialised, shuts that context down
(pyconnect.ros.node_shutdown, pyconnect.ros.shutdown, pyconnect.ros.shared_context). Every step
runs even when one before it failed (the failure is logged): a node is never left half shut
down. ``shutdown()`` called in a callback (or an ``async def`` handler on pyconnect's loop)
cannot wait for that callback, nor destroy the node under it: it starts the shutdown on a thread
of its own and returns, so the callback ends (a service sends its reply) before the node goes
down.

Names resolve like rclpy names: ``conn_name`` is relative to the node's namespace unless it
starts with ``/`` or ``~``; ``--ros-args -r chatter:=talk`` and ``-p name:=value`` from
``sys.argv`` (or ``args=``; ``cli_args=`` for this node only) apply.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import asyncio
import datetime
import os
import threading
import time
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from rclpy.context import Context
from rclpy.node import Node

from pyconnect.codecs.registry import Registry, default_registry
from pyconnect.errors import ConnectionTimeout, PyconnectError
from pyconnect.ros.agent_executor import AgentExecutor
from pyconnect.ros.agent_factory import build_agent, shared_options_for
from pyconnect.ros.agent_options import AgentOptions, OptionError
from pyconnect.ros.coroutines import CoroutineRunner
from pyconnect.ros.executor import DEFAULT_HANDOFF_AFTER
from pyconnect.ros.node_agent import NodeAgent
from pyconnect.ros.node_logging import NodeLogging
from pyconnect.ros.node_shutdown import NodeShutdown
from pyconnect.ros.option_checks import arity_problem, call_timeout, seconds_problem
from pyconnect.ros.recording import Recording
from pyconnect.ros.shared_context import join_context, leave_context
from pyconnect.ros.shutdown import ShutdownHooks
from pyconnect.ros.subscriber_agent import SubscriberAgent
from pyconnect.ros.waiting import EventLike

if TYPE_CHECKING:
    from typing_extensions import Unpack

StopFunc = Callable[..., Any]


def _check_keywords(
    name: str,
    *,
    log_dir: object,
    stop_func: object,
    registry: object,
    handle_signals: object,
    handoff_after: object,
) -> None:
    """Raise ``OptionError`` naming the first keyword of ``CustomNode`` whose value it cannot
    use, before anything is made: a str ``registry`` failed at the first agent with an
    ``AttributeError``, a str ``stop_func`` only in shutdown's log, and a negative
    ``handoff_after`` was taken."""
    problems: list[str | None] = []
    if log_dir is not None and not isinstance(log_dir, (str, os.PathLike)):
        problems.append(f"log_dir: expected a str, a Path or None, got {log_dir!r}")
    if stop_func is not None:
        if not callable(stop_func):
            hint = "; pass the function itself, not its name" if isinstance(stop_func, str) else ""
            problems.append(f"stop_func: expected a callable or None, got {stop_func!r}{hint}")
        else:
            problem = arity_problem(stop_func, 0, "shutdown calls it with no arguments")
            problems.append(None if problem is None else f"stop_func: {problem}")
    if registry is not None and not isinstance(registry, Registry):
        problems.append(f"registry: expected a pyconnect Registry or None, got {registry!r}")
    if not isinstance(handle_signals, bool | np.bool_):
        problems.append(f"handle_signals: expected bool, got {handle_signals!r}")
    problems.append(seconds_problem("handoff_after", handoff_after))
    for problem in problems:
        if problem is not None:
            raise OptionError(f"node {name!r}: {problem}")


class CustomNode(NodeLogging, NodeShutdown, Node):  # type: ignore[misc]
    """A ROS 2 node whose connections are agents: ``node.agents[name].send/get``.

    It is an ``rclpy.node.Node``: rclpy's own methods work on it, and it is its own
    ``ros_node``. ``loop=`` names an asyncio loop for ``async def`` handlers (default: one
    pyconnect starts when the first coroutine needs it).
    """

    def __init__(
        self,
        name: str,
        *,
        namespace: str | None = None,
        args: list[str] | None = None,
        cli_args: list[str] | None = None,
        context: Context | None = None,
        log_dir: str | Path | None = None,
        stop_func: StopFunc | None = None,
        registry: Registry | None = None,
        handle_signals: bool = True,
        handoff_after: float = DEFAULT_HANDOFF_AFTER,
        loop: asyncio.AbstractEventLoop | None = None,
    ) -> None:
        _check_keywords(
            name,
            log_dir=log_dir,
            stop_func=stop_func,
            registry=registry,
            handle_signals=handle_signals,
            handoff_after=handoff_after,
        )
        self.name = name
        self.registry = registry or default_registry
        self.stop_func = stop_func
        self.agents: dict[str, NodeAgent] = {}
        self._log_root = Path(log_dir) if log_dir is not None else None
        self._log_session: datetime.datetime | None = None
        self._log_session_dir: Path | None = None
        self._lock = threading.RLock()
        # Set under ``_lock`` as shutdown begins: what creates entities (add_agent, record,
        # start_log_subs) checks it under the same lock, so nothing is made while (or after)
        # the node's entities are destroyed.
        self._closing = False
        self._stopped = threading.Event()
        # Set once stop_func has run, before anything is destroyed: agents' waits in user
        # threads end there, and a call that fails after it reports the shutdown, not rclpy's
        # error.
        self._stopping = threading.Event()
        self._shutdown_lock = threading.Lock()
        self._shutting_down_in: int | None = None  # the thread running the shutdown
        self._shutdown_thread: threading.Thread | None = None
        self._spin_thread: threading.Thread | None = None
        self._main_waiting = False
        self._log_subs_timer: Any = None
        self._log_subs_recording: Recording | None = None
        self._recordings: list[Recording] = []
        self._log_dirs: dict[str, Path] = {}
        self.coroutines = CoroutineRunner(loop, name=f"pyconnect-asyncio-{name}")
        """Runs ``async def`` handlers (pyconnect.ros.coroutines)."""

        context = join_context(context, args)
        try:
            super().__init__(
                name,
                namespace=namespace,
                context=context,
                cli_args=cli_args,
            )
        except BaseException:
            leave_context(context)
            raise
        # Errors name the node as the graph knows it (remapped, namespaced); kept because
        # rclpy asks the node's handle, which shutdown destroys.
        self._qualified_name: str = super().get_fully_qualified_name()
        self._executor = AgentExecutor(
            context=context, handoff_after=handoff_after, on_error=self._on_executor_error
        )
        # Also sets rclpy's ``Node.executor`` (a weak reference; ``_executor`` keeps it alive).
        self._executor.add_node(self)
        self._hooks = ShutdownHooks(
            begin_shutdown=self._shutdown_in_background,
            main_is_waiting=lambda: self._main_waiting,
            handle_signals=handle_signals,
        )
        self._hooks.register_atexit(self.shutdown)

    # -- what agents use of their host (pyconnect.ros.agent_host) -------------------------------
    @property
    def ros_node(self) -> Node:
        """The rclpy node agents create their entities on: this node itself."""
        return self

    def get_fully_qualified_name(self) -> str:
        """rclpy's (``/robot1/left_cam`` for ``camera`` remapped), also after shutdown."""
        return self._qualified_name

    @property
    def qualified_name(self) -> str:
        """``get_fully_qualified_name()``: the name messages give the node."""
        return self._qualified_name

    @property
    def shutdown_event(self) -> threading.Event:
        """Set when shutdown has run ``stop_func`` and starts destroying the node's entities."""
        return self._stopping

    def wait_for(
        self,
        event: EventLike,
        timeout: float | None,
        *,
        poll: Callable[[], bool] | None = None,
    ) -> bool:
        """Wait until a callback sets ``event``, from any thread, even inside a callback."""
        return self._executor.wait_for(event, timeout, poll=poll)

    # -- agents --------------------------------------------------------------------------------
    def add_agent(
        self, config: Mapping[str, Any] | None = None, /, **options: Unpack[AgentOptions]
    ) -> NodeAgent:
        """Create an agent from keywords or a config dict (or both; keywords win).

        It is ``node.agents[agent_name or conn_name]``. Options per kind: see the agent classes
        and ``pyconnect.ros.agent_options``; one a kind does not use raises ``OptionError``.
        """
        given: dict[str, Any] = {**(config or {}), **options}
        key = given.get("agent_name") or given.get("conn_name")
        with self._lock:
            self._refuse_when_closed(f"add {key!r}")
            if key in self.agents:
                raise PyconnectError(
                    f"agent {key!r}: node {self._qualified_name!r} already has an agent of that "
                    "name; give one of them agent_name="
                )
            agent = build_agent(self, given)
            self.agents[agent.name] = agent
        # Wraps the new entities' callbacks (the executor watches for long ones).
        self._executor.adopt(self)
        return agent

    def _refuse_when_closed(self, what: str) -> None:
        """Raise ``PyconnectError`` once shutdown has begun (call with ``_lock`` held)."""
        if self._closing:
            raise PyconnectError(f"node {self._qualified_name!r} is shut down; cannot {what}")

    def add_agents(
        self, configs: Iterable[Mapping[str, Any]], **shared_options: Unpack[AgentOptions]
    ) -> list[NodeAgent]:
        """``add_agent`` per config; ``shared_options`` apply unless a config overrides them,
        and only to the kinds that use them (they are defaults)."""
        # One dict was iterated as its keys: "'str' object has no attribute 'get'".
        if isinstance(configs, Mapping | str | bytes) or not isinstance(configs, Iterable):
            hint = "; for one agent call add_agent(config)" if isinstance(configs, Mapping) else ""
            raise OptionError(
                f"add_agents: expected a list of agent dicts, got {type(configs).__name__}{hint}"
            )
        configs = list(configs)
        for index, config in enumerate(configs):  # before any agent is made
            if not isinstance(config, Mapping):
                raise OptionError(
                    f"add_agents: configs[{index}]: expected an agent dict, "
                    f"got {type(config).__name__}"
                )
        agents = []
        for config in configs:
            kind = config.get("conn_type", shared_options.get("conn_type"))
            shared = shared_options_for(kind, shared_options)
            agents.append(self.add_agent({**shared, **config}))
        return agents

    # -- running -------------------------------------------------------------------------------
    def spin(self, run_thread: bool = False) -> None:
        """Run the agents: in a daemon thread (``run_thread=True``) or here until shutdown."""
        with self._lock:
            if self._closing:
                raise PyconnectError(f"node {self._qualified_name!r} is shut down")
            if self._spin_thread is None:
                # Entities made with rclpy's own calls (an ActionClient on this node) are seen
                # here, before this call returns: moving an action to the elastic executor while
                # the caller already sends goals could strand their futures.
                self._executor.adopt(self)
                self._spin_thread = threading.Thread(
                    target=self._spin_forever, name=f"pyconnect-spin-{self.name}", daemon=True
                )
                self._spin_thread.start()
        if not run_thread:
            self.wait_for_shutdown()

    def listen(self, run_thread: bool = False) -> None:
        """``spin()`` by the design's other name: in a thread (``run_thread=True``) or here."""
        self.spin(run_thread=run_thread)

    def wait_for_shutdown(self, timeout: float | None = None) -> bool:
        """Block until the node is shut down (Ctrl-C, ``shutdown()``); False on timeout."""
        is_main = threading.current_thread() is threading.main_thread()
        if is_main:
            self._main_waiting = True
        try:
            deadline = None if timeout is None else time.monotonic() + timeout
            # Short waits keep the main thread responsive to signals.
            while not self._stopped.wait(_wait_step(deadline)):
                if deadline is not None and time.monotonic() >= deadline:
                    return False
        finally:
            if is_main:
                self._main_waiting = False
        thread = self._shutdown_thread
        if thread is not None and thread is not threading.current_thread():
            thread.join()
        return True

    def ok(self) -> bool:
        """True until the node is shut down."""
        return not self._stopping.is_set() and self.context.ok()

    @property
    def is_spinning(self) -> bool:
        return self._spin_thread is not None and self._spin_thread.is_alive()

    def ensure_spinning(self) -> None:
        """Spin in the background unless something spins already (never on this thread)."""
        self._executor.spin_in_background()

    def wait_until_connected(self, timeout: float | None = None) -> None:
        """Return when every sub has a message and every client sees its server.

        Raises ``ConnectionTimeout`` naming the agents still waiting.
        """
        timeout = call_timeout(
            timeout, None, where=f"node {self._qualified_name!r}: wait_until_connected"
        )
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            # Asked first: a shut-down node's entities are destroyed, asking them raises.
            if self._stopping.is_set():
                raise PyconnectError(f"node {self._qualified_name!r} is shut down")
            waiting = [agent for agent in list(self.agents.values()) if not agent.is_connected()]
            if not waiting:
                return
            remaining = None if deadline is None else deadline - time.monotonic()
            if remaining is not None and remaining <= 0:
                names = ", ".join(f"{agent.describe} ({_waiting_for(agent)})" for agent in waiting)
                raise ConnectionTimeout(
                    f"node {self._qualified_name!r}: still waiting after {timeout} s for {names}"
                )
            step = 0.02 if remaining is None else min(0.02, remaining)
            # Subscribers need their messages: nothing spinning, the node spins in the
            # background from now on (never on this thread; see AgentExecutor.wait_for).
            self._executor.spin_in_background()
            self._stopped.wait(step)

    # -- parameters (logging and recording: pyconnect.ros.node_logging) --------------------------
    def get_param(self, name: str, default: Any = None) -> Any:
        """A parameter's value (``--ros-args -p name:=value``, a params file, or declared),
        or ``default`` when unset. Overrides are read without declaring them, so
        ``declare_parameter``, ``get_parameter`` and ``ros2 param`` behave as on any rclpy
        node (a declared override's value; an undeclared name refused)."""
        if not self.has_parameter(name):
            override = self._parameter_overrides.get(name)
            value = None if override is None else override.value
            return default if value is None else value
        value = self.get_parameter(name).value
        return default if value is None else value

    def _destroy_ros_node(self) -> None:
        Node.destroy_node(self)

    def __enter__(self) -> CustomNode:
        return self

    # -- internals -----------------------------------------------------------------------------
    def _spin_forever(self) -> None:
        try:
            self._executor.spin()
        except Exception as error:
            self._log_error(f"executor stopped: {type(error).__name__}: {error}")

    def _on_executor_error(self, error: BaseException) -> None:
        self._log_error(f"callback raised {type(error).__name__}: {error}")


def _wait_step(deadline: float | None) -> float:
    if deadline is None:
        return 0.5
    return max(0.0, min(0.5, deadline - time.monotonic()))


def _waiting_for(agent: NodeAgent) -> str:
    if isinstance(agent, SubscriberAgent):
        return "no message yet"
    return "no server yet"
