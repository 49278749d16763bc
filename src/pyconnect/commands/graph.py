"""What the live-graph commands share: a hidden CLI node in its own context, waits, QoS choice.

Exit statuses follow ros2cli: 0 done, 1 the command could not do its work (no such topic,
service or type, a timeout, a bad value; one line on stderr), 2 a bad command line (argparse),
130 on Ctrl-C.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TextIO

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import (
    QoSPresetProfiles,
    QoSProfile,
)
from rclpy.signals import SignalHandlerOptions

# The options live where the parser can reach them without rclpy; kept importable from here.
from pyconnect.commands.live_options import (
    HIDDEN_PREFIX,
    QOS_PROFILES,
    add_qos,
    add_spin_time,
    expand_name,
)
from pyconnect.errors import PyconnectError
from pyconnect.ros.interfaces import interface_class
from pyconnect.typesys.classes import import_class
from pyconnect.typesys.names import full_type_name

__all__ = [
    "NODE_NAME_UNKNOWN",
    "PROGRAM",
    "QOS_PROFILES",
    "CommandFailed",
    "GraphSession",
    "add_qos",
    "add_spin_time",
    "endpoint_failure",
    "endpoints_named",
    "expand_name",
    "graph_session",
    "message_class",
    "preset_qos",
    "report_failure",
    "settle",
    "topic_endpoints",
    "topic_types",
]

PROGRAM = "pyconnect"
NODE_NAME_UNKNOWN = "_NODE_NAME_UNKNOWN_"  # what rmw names the node of an endpoint until it knows


class CommandFailed(PyconnectError):
    """The command could not do its work: one line on stderr, exit status 1."""


def report_failure(error: Exception, err: TextIO) -> int:
    """Print ``error`` as ros2cli does a failed verb (one line) and return 1."""
    message = " ".join(str(error).split()) or type(error).__name__
    print(f"{PROGRAM}: error: {message}", file=err)
    return 1


class GraphSession:
    """A hidden node (``_pyconnect_cli_<pid>``) in a private context, spun on this thread."""

    def __init__(self, name: str) -> None:
        self._interrupted = False
        self._spinning = False
        self._deferring = 0
        self._previous_sigint: Any = None
        self.context = Context()
        rclpy.init(context=self.context, signal_handler_options=SignalHandlerOptions.NO)
        if threading.current_thread() is threading.main_thread():
            self._previous_sigint = signal.signal(signal.SIGINT, self._on_sigint)
        try:
            self.node = Node(
                f"{HIDDEN_PREFIX}pyconnect_{name}_{os.getpid()}",
                context=self.context,
                start_parameter_services=False,
            )
            self.executor = SingleThreadedExecutor(context=self.context)
            self.executor.add_node(self.node)
        except BaseException:
            self.context.try_shutdown()
            raise

    def spin_once(self, timeout: float = 0.05) -> None:
        self._spinning = True
        try:
            self.executor.spin_once(timeout_sec=timeout)
        finally:
            self._spinning = False
        self._raise_deferred()

    def _on_sigint(self, _signum: int, _frame: Any) -> None:
        # Ctrl-C raised inside rclpy's executor can leave a half-built Task whose __del__
        # prints a traceback at exit: while it spins, the interrupt waits for the spin to end.
        if self._spinning or self._deferring:
            self._interrupted = True
        else:
            raise KeyboardInterrupt

    def _raise_deferred(self) -> None:
        if self._interrupted and not self._spinning and not self._deferring:
            self._interrupted = False
            raise KeyboardInterrupt

    @contextmanager
    def interrupts_deferred(self) -> Iterator[None]:
        """Ctrl-C inside the block is raised when it ends: for work that must not stop halfway
        (a bag file being split or finished)."""
        self._deferring += 1
        try:
            yield
        finally:
            self._deferring -= 1
        self._raise_deferred()

    def spin_for(self, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.spin_once(min(0.05, max(0.0, deadline - time.monotonic())))

    def spin_until(self, done: Callable[[], bool], timeout: float | None) -> bool:
        """Spin until ``done()`` (True) or ``timeout`` seconds pass (False); None: forever."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while not done():
            if deadline is not None and time.monotonic() >= deadline:
                return False
            self.spin_once()
        return True

    def close(self) -> None:
        try:
            self.executor.shutdown(timeout_sec=1.0)
            self.node.destroy_node()
        finally:
            self.context.try_shutdown()
            if self._previous_sigint is not None:
                signal.signal(signal.SIGINT, self._previous_sigint)
                self._previous_sigint = None


@contextmanager
def graph_session(name: str) -> Iterator[GraphSession]:
    """A ``GraphSession`` closed on leaving the block (also on Ctrl-C)."""
    session = GraphSession(name)
    try:
        yield session
    finally:
        session.close()


SETTLE_ROUNDS = 10
"""Spins in a row (0.05 s each on the CLI's idle node: about 0.5 s) in which what discovery knows
of a topic must not change before it counts as known. Processes are discovered one by one: a
second publisher appeared up to 0.4 s after the first on an idle machine, so a type or QoS read
at the first sight of a topic could be one publisher's only. This narrows the race, it cannot
close it: Fast DDS sometimes finds a process only at its next announcement (every 3 s), which
no short wait covers (echo's QoS follows late publishers anyway: pyconnect.commands.live_qos)."""


def settle(session: GraphSession, snapshot: Callable[[], object], *, timeout: float | None) -> None:
    """Spin until ``snapshot()`` (what discovery knows) gave the same value ``SETTLE_ROUNDS``
    spins in a row, or ``timeout`` s pass (None: no limit)."""
    deadline = None if timeout is None else time.monotonic() + timeout
    last = snapshot()
    steady = 0
    while steady < SETTLE_ROUNDS:
        if deadline is not None and time.monotonic() >= deadline:
            return
        session.spin_once()
        now = snapshot()
        steady = steady + 1 if now == last else 0
        last = now


def topic_endpoints(session: GraphSession, topic: str) -> list[str]:
    """Every endpoint of ``topic`` discovery knows, with its node, type, GID and QoS: a
    snapshot for ``settle`` (a publisher found, or its node named, changes it)."""
    node = session.node
    found = [
        *node.get_publishers_info_by_topic(topic),
        *node.get_subscriptions_info_by_topic(topic),
    ]
    return sorted(str(endpoint) for endpoint in found)


def topic_types(session: GraphSession, topic: str, *, timeout: float | None) -> list[str]:
    """The types seen on ``topic`` (more than one when its endpoints disagree), waiting up to
    ``timeout`` s for it to appear and then for its endpoints to settle (``settle``)."""
    deadline = None if timeout is None else time.monotonic() + timeout

    def known() -> bool:
        return bool(dict(session.node.get_topic_names_and_types()).get(topic))

    if not session.spin_until(known, timeout):
        raise CommandFailed(
            f"topic [{topic}] does not appear to be published yet; could not determine its type"
        )
    # The types read at the first sight may be one process's: the rest of --timeout settles.
    left = None if deadline is None else max(0.0, deadline - time.monotonic())
    settle(session, lambda: topic_endpoints(session, topic), timeout=left)
    types: list[str] = dict(session.node.get_topic_names_and_types()).get(topic, [])
    return types


def message_class(type_name: str) -> Any:
    """The rclpy class of a message type, the parts of services and actions included.

    A topic's type can be such a part (``test_msgs/action/Fibonacci_FeedbackMessage`` on an
    action's feedback topic is the class ``Fibonacci.Impl.FeedbackMessage``), which is no
    attribute of its package's module: typesys knows where rosidl puts each part.
    """
    try:
        return interface_class(type_name, kind="msg")
    except PyconnectError as error:
        try:
            return import_class(full_type_name(type_name))
        except PyconnectError:
            raise error from None  # says what users need: the type is not installed


def endpoint_failure(error: Exception, what: str) -> CommandFailed:
    """``CommandFailed`` for rcl refusing to create an endpoint (an RCLError): one line."""
    # rcl appends where in its C sources each layer failed: no use to the user.
    reason = str(error).split(", at /")[0]
    return CommandFailed(f"cannot {what}: {reason}")


def endpoints_named(session: GraphSession, topics: list[str] | None = None) -> bool:
    """True when the node of every endpoint seen on ``topics`` (default: every topic) is known.

    rmw learns endpoints from DDS discovery but the names of their nodes from each process's
    ``ros_discovery_info`` message, which comes later: in between, a process's topics are listed
    and its nodes are not (``node list`` printed nothing while ``topic list`` had the topics).
    """
    node = session.node
    names = topics if topics is not None else [n for n, _ in node.get_topic_names_and_types()]
    return all(
        endpoint.node_name != NODE_NAME_UNKNOWN
        for name in names
        for endpoints in (
            node.get_publishers_info_by_topic(name),
            node.get_subscriptions_info_by_topic(name),
        )
        for endpoint in endpoints
    )


def preset_qos(profile: str) -> QoSProfile:
    """The preset ``--qos-profile`` names (one of ``QOS_PROFILES``)."""
    if profile not in QOS_PROFILES:
        raise CommandFailed(
            f"--qos-profile: unknown profile {profile!r}; choose from {', '.join(QOS_PROFILES)}"
        )
    named: QoSProfile = QoSPresetProfiles.get_from_short_key(profile)
    return named
