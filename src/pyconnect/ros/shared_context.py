"""The rclpy contexts pyconnect initialised, shut down when the last node using one ends.

A ``CustomNode`` whose context is not initialised yet initialises it (without rclpy's signal
handlers); every later node on that context shares it. Shutting one node down must not pull the
context from under the others (their publishers would fail with "context is invalid"), so the
context is shut down when the last of them ends. A context the user initialised is theirs: no
node shuts it down. The default context is shut down through ``try_shutdown()`` without
naming it, which makes rclpy start a fresh default one, so a later node works again.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence

import rclpy
from rclpy.context import Context
from rclpy.signals import SignalHandlerOptions
from rclpy.utilities import get_default_context, try_shutdown

_lock = threading.Lock()
_users: dict[int, int] = {}  # id(context) -> live nodes on a context pyconnect initialised


def join_context(context: Context | None, args: Sequence[str]) -> Context:
    """The context a new node runs on (initialised if needed), counted as one more user."""
    with _lock:
        chosen = context if context is not None else get_default_context()
        if not chosen.ok():
            rclpy.init(
                args=list(args), context=chosen, signal_handler_options=SignalHandlerOptions.NO
            )
            _users[id(chosen)] = 0
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
        if context is get_default_context():
            try_shutdown()  # and rclpy makes a new default context for later nodes
        else:
            try_shutdown(context=context)
