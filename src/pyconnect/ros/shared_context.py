"""The rclpy contexts pyconnect initialised, shut down when the last node using one ends.

A ``CustomNode`` whose context is not initialised yet initialises it (without rclpy's signal
handlers); every later node on that context shares it. Shutting one node down must not pull the
context from under the others (their publishers would fail with "context is invalid"), so the
context is shut down when the last of them ends. A context the user initialised is theirs: no
node shuts it down. The default context is shut down through ``try_shutdown()`` without
naming it, which makes rclpy start a fresh default one, so a later node works again.

The ROS arguments (``--ros-args ...``) of a context are those it was initialised with: a later
node's ``args=`` cannot change them, so one with other ROS arguments is refused (``cli_args=``
gives a node arguments of its own).
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Sequence

import rclpy
from rclpy.context import Context
from rclpy.signals import SignalHandlerOptions
from rclpy.utilities import get_default_context, try_shutdown

from pyconnect.errors import PyconnectError

_lock = threading.Lock()
_users: dict[int, int] = {}  # id(context) -> live nodes on a context pyconnect initialised
_ros_args: dict[int, list[str]] = {}  # id(context) -> the ROS arguments it was initialised with


def join_context(context: Context | None, args: Sequence[str] | None) -> Context:
    """The context a new node runs on (initialised if needed), counted as one more user.

    ``args`` None: the process's (``sys.argv``). Raises ``PyconnectError`` when the context
    pyconnect initialised for an earlier node has other ROS arguments than ``args`` given.
    """
    with _lock:
        chosen = context if context is not None else get_default_context()
        if not chosen.ok():
            given = sys.argv if args is None else args
            rclpy.init(
                args=list(given), context=chosen, signal_handler_options=SignalHandlerOptions.NO
            )
            _users[id(chosen)] = 0
            _ros_args[id(chosen)] = _ros_arguments(given)
        elif args is not None and id(chosen) in _ros_args:
            _refuse_other_ros_args(_ros_args[id(chosen)], _ros_arguments(args))
        if id(chosen) in _users:
            _users[id(chosen)] += 1
        return chosen


def leave_context(context: Context) -> None:
    """One user fewer; the last user of a context pyconnect initialised shuts it down."""
    with _lock:
        users = _users.get(id(context))
        if users is None:
            return  # the user's own context
        if users > 1:
            _users[id(context)] = users - 1
            return
        del _users[id(context)]
        _ros_args.pop(id(context), None)
        if context is get_default_context():
            try_shutdown()  # and rclpy makes a new default context for later nodes
        else:
            try_shutdown(context=context)


def _ros_arguments(args: Sequence[str]) -> list[str]:
    """The ROS arguments in ``args``: those between ``--ros-args`` and ``--`` (or the end)."""
    found: list[str] = []
    inside = False
    for arg in args:
        if arg == "--ros-args":
            inside = True
        elif inside and arg == "--":
            inside = False
        elif inside:
            found.append(arg)
    return found


def _refuse_other_ros_args(initial: list[str], given: list[str]) -> None:
    if given == initial:
        return
    raise PyconnectError(
        "args=: the process's ROS arguments are set once, by the first node (per context): "
        f"expected {_shown(initial)} as that node gave them (or no args=), got {_shown(given)}; "
        "give this node arguments of its own with cli_args=['--ros-args', ...]"
    )


def _shown(ros_args: list[str]) -> str:
    return repr(["--ros-args", *ros_args]) if ros_args else "no ROS arguments"
