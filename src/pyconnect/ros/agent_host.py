"""``AgentHost``: what an agent may use of the node that holds it, and nothing more.

Agents never import ``CustomNode``: they see their node through this protocol, so ``ros/``
has no import circle (custom_node -> agent_factory -> agents -> agent_host) and a new host
(a test double, a zenoh peer) only has to provide these few members.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from pyconnect.ros.waiting import EventLike

if TYPE_CHECKING:
    from rclpy.node import Node

    from pyconnect.codecs.registry import Registry
    from pyconnect.ros.coroutines import CoroutineRunner


class AgentHost(Protocol):
    """The node side of an agent: where it creates entities, waits, logs and runs coroutines."""

    @property
    def name(self) -> str:
        """The node's name as given (log folders and thread names use it)."""
        ...

    @property
    def qualified_name(self) -> str:
        """The node's fully qualified name, as remapped (``/robot1/left_cam``): for messages."""
        ...

    @property
    def registry(self) -> Registry:
        """The codec registry agents look their codecs up in."""
        ...

    @property
    def ros_node(self) -> Node:
        """The rclpy node the agent creates its publishers, services, timers... on."""
        ...

    @property
    def shutdown_event(self) -> threading.Event:
        """Set once the node is shut down: waits in user threads end early."""
        ...

    @property
    def coroutines(self) -> CoroutineRunner:
        """Runs ``async def`` handlers (on the node's own loop, or the user's)."""
        ...

    def get_logger(self) -> Any:
        """The node's rclpy logger."""
        ...

    def wait_for(
        self,
        event: EventLike,
        timeout: float | None,
        *,
        poll: Callable[[], bool] | None = None,
    ) -> bool:
        """Wait until ``event`` is set by a callback (safe inside a callback); False on timeout."""
        ...

    def ensure_spinning(self) -> None:
        """Spin in the background unless something spins already (an answer needs callbacks)."""
        ...

    def agent_log_dir(self, agent_name: str) -> Path:
        """This session's log folder of ``agent_name``: one folder per agent, made once."""
        ...

    def shutdown(self) -> None:
        """Shut the node down; called in a callback, once that callback has ended."""
        ...
