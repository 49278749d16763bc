"""``Peer``: a program's agents on zenoh, with ``CustomNode``'s API and no rclpy.

A peer is one zenoh session that shows itself as one ROS node (rmw_zenoh's ``NN`` token with
the peer's name; namespace and enclave ``/``, written ``%``), in domain ``domain_id``
(default ``ROS_DOMAIN_ID``, else 0). Its agents are rmw_zenoh publishers, subscriptions,
services and clients, so ROS nodes that run ``rmw_zenoh_cpp`` and other peers see them as
ordinary ROS entities. Samples are handled as they arrive (zenoh runs on its own threads from
the start); ``spin()`` only blocks until shutdown, ``spin(run_thread=True)`` returns at once.
A peer applies pyconnect's glibc malloc settings to its process (pyconnect.ros.large_messages;
``PYCONNECT_LARGE_MESSAGES=0`` leaves malloc alone): multi-MB payloads then reuse memory instead
of faulting in fresh pages on every message.

Shutdown — ``shutdown()``, leaving ``with``, Ctrl-C, SIGTERM or interpreter exit — runs
``stop_func`` once, closes the agents and the session, and (on a signal) the process exits 0
without a traceback: the same process-wide handlers as ``CustomNode`` (pyconnect.ros.shutdown,
which imports no rclpy). The agents close all at once, so handlers still blocked keep a shutdown
waiting ``AGENTS_CLOSE_SECONDS`` in all, however many there are; ``add_agent`` is refused from
the moment the shutdown begins.
"""

# zenoh's stubs leave undeclare() and close() unannotated.
# mypy: disable-error-code="no-untyped-call"

from __future__ import annotations

import itertools
import os
import re
import sys
import threading
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import zenoh

from pyconnect.codecs.registry import Registry, default_registry
from pyconnect.errors import ConnectionTimeout, PyconnectError, TransportError, type_name_of
from pyconnect.ros.agent_options import OptionError
from pyconnect.ros.large_messages import apply_malloc_settings
from pyconnect.ros.option_checks import call_timeout, check_options, plain_option_problem
from pyconnect.ros.option_checks import shared_options as shared_options_of
from pyconnect.ros.shutdown import ShutdownHooks, ShutsDownOnExit
from pyconnect.transport import rmw_zenoh_keys as keys
from pyconnect.transport.async_handlers import spare_coroutine
from pyconnect.transport.graph import Graph
from pyconnect.transport.peer_agent import PeerAgent, logger
from pyconnect.transport.peer_options import (
    NOT_ON_A_PEER,
    PEER_AGENT_CLASSES,
    PEER_OPTIONS,
    TAKES_QOS,
    PeerAgentOptions,
    accepted_options,
    check_values,
    depth_from_qos,
)
from pyconnect.transport.ros_names import RosNameError, namespace_problem, node_name_problem
from pyconnect.transport.session_config import session_config

if TYPE_CHECKING:
    from typing_extensions import Unpack

StopFunc = Callable[..., Any]

DEFAULT_MAX_PAYLOAD_BYTES = 256 * 1024 * 1024
AGENTS_CLOSE_SECONDS = 6.0
"""How long a shutdown waits for its agents' closes in all (they run at once): an agent's own
close gives its handler 5 s, and then undeclares its entities."""


# rmw takes a domain id as a size_t and keeps SIZE_MAX for "the default" (rmw_zenoh's
# rmw_init maps it to 0): every other value is a domain of its own, on DDS or zenoh.
_LARGEST_DOMAIN_ID = 2**64 - 2
_EXPECTED_DOMAIN_ID = f"expected an int from 0 to {_LARGEST_DOMAIN_ID}"


def checked_domain_id(value: object, *, what: str = "domain_id") -> int:
    """``value`` as a domain id, or ``TransportError`` naming ``what``: an int (not a bool)
    that rmw takes (a size_t below SIZE_MAX). (Any other value would go into every key and
    token, making a domain no ROS node joins.)"""
    if isinstance(value, bool) or not isinstance(value, int):
        raise TransportError(
            f"{what}: {_EXPECTED_DOMAIN_ID}, got {value!r} ({type_name_of(value)})"
        )
    if not 0 <= value <= _LARGEST_DOMAIN_ID:
        raise TransportError(f"{what}: {_EXPECTED_DOMAIN_ID}, got {value!r}")
    return value


# rcl_get_default_domain_id reads ROS_DOMAIN_ID with strtoul(text, &end, 0) and refuses
# trailing text: decimal, 0x... hex, or 0... octal ("010" is 8 to every ROS node).
_ROS_DOMAIN_ID_FORMS = ((r"0[xX][0-9a-fA-F]+", 16), (r"0[0-7]*", 8), (r"[1-9][0-9]*", 10))


def default_domain_id() -> int:
    """``ROS_DOMAIN_ID`` read as rcl reads it (unset or empty: 0)."""
    text = os.environ.get("ROS_DOMAIN_ID", "").strip()
    if not text:
        return 0
    for pattern, base in _ROS_DOMAIN_ID_FORMS:
        if re.fullmatch(pattern, text):
            return checked_domain_id(int(text, base), what="ROS_DOMAIN_ID")
    raise TransportError(f"ROS_DOMAIN_ID: {_EXPECTED_DOMAIN_ID}, got {text!r}")


def checked_payload_limit(value: object) -> int | None:
    """``max_payload_bytes`` as given, when it is None (no limit) or an int (not a bool) >= 1;
    ``PyconnectError`` otherwise (a str failed every sample, 0 or less dropped them all)."""
    expected = "max_payload_bytes: expected None or an int >= 1"
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int):
        raise PyconnectError(f"{expected}, got {value!r} ({type_name_of(value)})")
    if value < 1:
        raise PyconnectError(f"{expected}, got {value!r}")
    return value


def node_namespace(name: str, namespace: str) -> str:
    """The peer's namespace, ``/``-rooted as rcl_node_init makes it, once ``name`` and it pass
    rmw's node name and namespace rules (``RosNameError`` names the peer and the rule)."""
    for what, value in (("name", name), ("namespace", namespace)):
        if not isinstance(value, str):
            raise RosNameError(f"peer {name!r}: {what}: expected a str, got {type_name_of(value)}")
    problem = node_name_problem(name)
    if problem is not None:
        raise RosNameError(f"peer {name!r}: node name {problem}")
    rooted = namespace if namespace.startswith("/") else f"/{namespace}"
    problem = namespace_problem(rooted)
    if problem is not None:
        raise RosNameError(f"peer {name!r}: namespace {rooted!r} {problem}")
    return rooted


class Peer(ShutsDownOnExit):
    """A zenoh peer whose connections are agents: ``peer.agents[name].send/get``."""

    def __init__(
        self,
        name: str,
        *,
        namespace: str = "/",
        domain_id: int | None = None,
        config: str | Path | zenoh.Config | None = None,
        connect: Sequence[str] | None = None,
        listen: Sequence[str] | None = None,
        mode: str | None = None,
        registry: Registry | None = None,
        max_payload_bytes: int | None = DEFAULT_MAX_PAYLOAD_BYTES,
        stop_func: StopFunc | None = None,
        handle_signals: bool = True,
    ) -> None:
        # Checked before the session opens: a name zenoh refuses would leave it open, and
        # one rcl refuses would make a node no ROS tool can address.
        self.name = name
        self.namespace = node_namespace(name, namespace)
        try:
            self.domain_id = (
                default_domain_id() if domain_id is None else checked_domain_id(domain_id)
            )
            self.max_payload_bytes = checked_payload_limit(max_payload_bytes)
        except PyconnectError as error:
            raise type(error)(f"peer {name!r}: {error}") from None
        self.registry = registry or default_registry
        self.stop_func = stop_func
        self.agents: dict[str, PeerAgent] = {}
        self._lock = threading.RLock()
        self._stopped = threading.Event()
        # Set when shutdown begins: calls racing the closing session end as shut down.
        self._stopping = threading.Event()
        # Set once stop_func has run and the agents to close are listed: no agent after that.
        self._closing = False
        self._shutting_down_in: int | None = None  # the thread running the shutdown
        self._shutdown_lock = threading.Lock()
        self._shutdown_thread: threading.Thread | None = None
        self._main_waiting = False
        self._ids = itertools.count()
        # Multi-MB payloads (images) otherwise cost a page-fault storm per message.
        apply_malloc_settings()
        self.config = session_config(config=config, connect=connect, listen=listen, mode=mode)
        """The zenoh configuration the session was opened with (file settings kept as given)."""
        try:
            self.session = zenoh.open(self.config)
        except Exception as error:
            raise TransportError(f"peer {name!r}: cannot open a zenoh session: {error}") from error
        self.zid = str(self.session.zid())
        self.identity = keys.NodeIdentity(
            domain_id=self.domain_id,
            zid=self.zid,
            node_id=next(self._ids),
            name=name,
            namespace=self.namespace,
        )
        self.graph = Graph(self.session, self.domain_id)
        self.node_token_key = keys.node_token(self.identity)
        self._node_token = self.session.liveliness().declare_token(self.node_token_key)
        self._hooks = ShutdownHooks(
            begin_shutdown=self._shutdown_in_background,
            main_is_waiting=lambda: self._main_waiting,
            handle_signals=handle_signals,
        )
        self._hooks.register_atexit(self.shutdown, before_threads_end=True)

    # -- tokens --------------------------------------------------------------------------------
    def entity_token(
        self, *, kind: str, name: str, type_name: str, type_hash: str, qos: str
    ) -> str:
        """The liveliness key of a new entity of this peer's node (ids count per session)."""
        with self._lock:
            entity_id = next(self._ids)
        return keys.entity_token(
            self.identity,
            entity_id=entity_id,
            kind=kind,
            name=name,
            type_name=type_name,
            type_hash=type_hash,
            qos=qos,
        )

    # -- agents --------------------------------------------------------------------------------
    def add_agent(
        self, config: Mapping[str, Any] | None = None, /, **options: Unpack[PeerAgentOptions]
    ) -> PeerAgent:
        """Create an agent from keywords or a config dict (or both; keywords win), as
        ``CustomNode.add_agent`` does; it is ``agents[agent_name or conn_name]``.

        Options per kind: the agent classes' keyword-only ``__init__``, plus ``qos=`` on a sub
        or pub (its depth: ``depth_from_qos``). An option the kind does not take, or one no
        kind takes on a peer (``do_log_msg``...), raises ``OptionError`` naming it.
        """
        given: dict[str, Any] = {**(config or {}), **options}
        conn_name = given.pop("conn_name", None)
        conn_type = given.pop("conn_type", None)
        agent_name = given.pop("agent_name", None)
        if not isinstance(conn_name, str) or not conn_name:
            raise OptionError(f"agent config: conn_name must be a non-empty str, got {conn_name!r}")
        problem = plain_option_problem("agent_name", agent_name)
        if problem is not None:  # before it names the agent: 5 became the key in agents
            raise OptionError(f"agent {conn_name!r}: {problem}")
        key = agent_name or conn_name
        with self._lock:
            # Refused once shutdown has listed the agents to close (under this lock, after
            # stop_func, which may add one to say goodbye): one added later would never be
            # closed (a timer ticking on after shutdown).
            if self._closing:
                raise PyconnectError(f"peer {self.name!r} is shut down; cannot add {key!r}")
            if key in self.agents:
                raise PyconnectError(
                    f"agent {key!r}: peer {self.name!r} already has an agent of that name; "
                    "give one of them agent_name="
                )
            if conn_type is None:
                raise OptionError(f"agent {key!r}: missing option 'conn_type'")
            agent_class = PEER_AGENT_CLASSES.get(conn_type)
            if agent_class is None:
                raise PyconnectError(
                    f"agent {key!r}: conn_type {conn_type!r} is not available on a peer; expected "
                    f"one of {', '.join(repr(kind) for kind in PEER_AGENT_CLASSES)}"
                )
            where = f"agent {key!r} ({conn_type})"
            if "qos" in given and conn_type in TAKES_QOS:
                if "depth" in given:
                    raise OptionError(f"{where}: give qos= or depth=, not both")
                depth = depth_from_qos(given.pop("qos"), where)
                if depth is not None:
                    given["depth"] = depth
            check_options(
                agent_class,
                given,
                where,
                kind=conn_type,
                known=PEER_OPTIONS,
                unavailable=NOT_ON_A_PEER,
            )
            check_values(conn_type, given, where)
            try:
                agent = agent_class(self, conn_name=conn_name, agent_name=agent_name, **given)
            except PyconnectError as error:
                if str(error).startswith("agent "):
                    raise
                raise type(error)(f"{where}: {error}") from error
            self.agents[key] = agent
            return agent

    def add_agents(
        self, configs: Iterable[Mapping[str, Any]], **shared_options: Unpack[PeerAgentOptions]
    ) -> list[PeerAgent]:
        """``add_agent`` per config; ``shared_options`` apply unless a config overrides them,
        and only to the kinds that take them (they are defaults, as on ``CustomNode``)."""
        agents = []
        for config in configs:
            kind = config.get("conn_type", shared_options.get("conn_type"))
            agent_class = PEER_AGENT_CLASSES.get(kind) if isinstance(kind, str) else None
            accepted = None if agent_class is None else accepted_options(agent_class)
            shared = shared_options_of(accepted, shared_options, known=PEER_OPTIONS)
            agents.append(self.add_agent({**shared, **config}))
        return agents

    # -- running -------------------------------------------------------------------------------
    def spin(self, run_thread: bool = False) -> None:
        """Block until shutdown; ``run_thread=True`` returns at once (agents run either way)."""
        if self._stopped.is_set():
            raise PyconnectError(f"peer {self.name!r} is shut down")
        if not run_thread:
            self.wait_for_shutdown()

    def listen(self, run_thread: bool = False) -> None:
        """``spin()`` by the design's other name: here until shutdown, or ``run_thread=True``
        returns at once (as ``CustomNode.listen``)."""
        self.spin(run_thread=run_thread)

    def ok(self) -> bool:
        """True until the peer's shutdown begins."""
        return not self._stopping.is_set()

    def wait_for_shutdown(self, timeout: float | None = None) -> bool:
        """Block until the peer is shut down (Ctrl-C, ``shutdown()``); False on timeout."""
        is_main = threading.current_thread() is threading.main_thread()
        if is_main:
            self._main_waiting = True
        try:
            deadline = None if timeout is None else time.monotonic() + timeout
            while not self._stopped.wait(_step(deadline, 0.5)):
                if deadline is not None and time.monotonic() >= deadline:
                    return False
        finally:
            if is_main:
                self._main_waiting = False
        thread = self._shutdown_thread
        if thread is not None and thread is not threading.current_thread():
            thread.join()
        return True

    def wait_for_graph(self, condition: Callable[[], bool], deadline: float | None) -> bool:
        """Wait until ``condition()`` holds for the graph; False at ``deadline`` or shutdown."""
        with self.graph.changed:
            while not condition():
                if not self.ok():
                    return False
                if deadline is not None and time.monotonic() >= deadline:
                    return False
                self.graph.changed.wait(_step(deadline, 0.1))
        return True

    def wait_until_connected(self, timeout: float | None = None) -> None:
        """Return when every sub has a message from a publisher alive now and every client
        sees a server now; raises ``ConnectionTimeout`` naming the agents still waiting."""
        timeout = call_timeout(timeout, None, where=f"peer {self.name!r}: wait_until_connected")
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            waiting = [agent for agent in list(self.agents.values()) if not agent.is_connected()]
            if not waiting:
                return
            if self._stopped.is_set():
                raise PyconnectError(f"peer {self.name!r} was shut down while waiting")
            if deadline is not None and time.monotonic() >= deadline:
                names = ", ".join(f"{agent.describe} ({agent.waiting_for()})" for agent in waiting)
                raise ConnectionTimeout(
                    f"peer {self.name!r}: still waiting after {timeout} s for {names}"
                )
            self._stopped.wait(_step(deadline, 0.02))

    def node_names(self) -> list[str]:
        """Names of the ROS nodes (peers and rmw_zenoh nodes) alive in this domain now."""
        return self.graph.node_names()

    # -- shutdown ------------------------------------------------------------------------------
    def shutdown(self) -> None:
        """Stop everything once: ``stop_func``, agents, tokens, the zenoh session.

        Called from one of the peer's own threads (a handler), it starts the shutdown on a
        thread of its own and returns: the shutdown waits for the handler to finish (a service
        still sends its reply), and ``spin()`` returns when everything is closed.
        """
        current = threading.current_thread()
        if current.daemon and current.name.startswith("pyconnect-"):  # an agent's thread
            spare_coroutine(current)  # the handler that asked goes on to its answer
            self._shutdown_in_background()
            return
        if self._shutting_down_in == threading.get_ident():
            return  # stop_func asked again, on the thread already shutting down: it deadlocked
        with self._shutdown_lock:
            if self._stopped.is_set():
                return
            self._stopping.set()
            self._shutting_down_in = threading.get_ident()
            try:
                self._shut_down()
            finally:
                self._shutting_down_in = None
                self._stopped.set()

    def _shut_down(self) -> None:
        if self.stop_func is not None:
            try:
                self.stop_func()
            except Exception as error:
                logger.error(
                    "peer %r: stop_func raised %s: %s", self.name, type(error).__name__, error
                )
        with self._lock:  # an add_agent in progress ends first, and later ones are refused
            self._closing = True
            agents = list(self.agents.values())
        self._close_agents(agents)
        self.graph.close()
        try:
            self._node_token.undeclare()
            self.session.close()
        except Exception as error:
            print(f"[pyconnect] peer {self.name}: closing zenoh failed: {error}", file=sys.stderr)
        self._hooks.restore()

    def _close_agents(self, agents: list[PeerAgent]) -> None:
        """Close ``agents`` all at once, waiting ``AGENTS_CLOSE_SECONDS`` for them in total.

        Each close waits up to 5 s for its agent's handler; one after another, a few blocked
        handlers took longer than a supervisor waits between SIGTERM and SIGKILL.
        """
        deadline = time.monotonic() + AGENTS_CLOSE_SECONDS
        closing: list[tuple[PeerAgent, threading.Thread]] = []
        for agent in agents:
            thread = threading.Thread(
                target=_close_agent, args=(agent,), name=f"pyconnect-close-{agent.name}"
            )
            # A daemon: one stuck past the deadline must not hold the interpreter's exit.
            thread.daemon = True
            try:
                thread.start()
            except RuntimeError:  # no new threads at interpreter exit: close it here
                _close_agent(agent)
                continue
            closing.append((agent, thread))
        for _agent, thread in closing:
            thread.join(max(0.0, deadline - time.monotonic()))
        stuck = [agent.describe for agent, thread in closing if thread.is_alive()]
        if stuck:
            logger.warning(
                "peer %r: closing the session after %s s with agents still closing: %s",
                self.name,
                AGENTS_CLOSE_SECONDS,
                ", ".join(stuck),
            )

    def __enter__(self) -> Peer:
        return self


def _close_agent(agent: PeerAgent) -> None:
    try:
        agent.close()
    except Exception as error:
        logger.error("%s: close failed: %r", agent.describe, error)


def _step(deadline: float | None, longest: float) -> float:
    if deadline is None:
        return longest
    return max(0.0, min(longest, deadline - time.monotonic()))
