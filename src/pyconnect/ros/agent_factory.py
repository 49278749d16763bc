"""``make_agent`` and ``AGENT_CLASS_DICT``: the one place that maps ``conn_type`` to an agent class.

New agent kinds register here: ``AGENT_CLASS_DICT['my_kind'] = MyAgent`` (a ``NodeAgent``
subclass whose keyword-only ``__init__`` options are the config keys).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from pyconnect.errors import PyconnectError
from pyconnect.ros.action_client_agent import ActionClientAgent
from pyconnect.ros.action_server_agent import ActionServerAgent
from pyconnect.ros.node_agent import NodeAgent
from pyconnect.ros.publisher_agent import PublisherAgent
from pyconnect.ros.service_agents import ServiceClientAgent, ServiceServerAgent
from pyconnect.ros.subscriber_agent import SubscriberAgent
from pyconnect.ros.timer_agent import TimerAgent

if TYPE_CHECKING:
    from pyconnect.ros.custom_node import CustomNode

AGENT_CLASS_DICT: dict[str, type[NodeAgent]] = {
    "sub": SubscriberAgent,
    "pub": PublisherAgent,
    "service_client": ServiceClientAgent,
    "service_server": ServiceServerAgent,
    "action_client": ActionClientAgent,
    "action_server": ActionServerAgent,
    "timer": TimerAgent,
}


def make_agent(
    node: CustomNode,
    *,
    conn_name: str,
    conn_type: str,
    agent_name: str | None = None,
    **options: Any,
) -> NodeAgent:
    """Build the agent of kind ``conn_type``; unknown kinds and options raise ``PyconnectError``."""
    name = agent_name or conn_name
    agent_class = AGENT_CLASS_DICT.get(conn_type)
    if agent_class is None:
        raise PyconnectError(
            f"agent {name!r}: unknown conn_type {conn_type!r}; expected one of "
            f"{', '.join(repr(kind) for kind in AGENT_CLASS_DICT)}"
        )
    try:
        return agent_class(node, conn_name=conn_name, agent_name=agent_name, **options)
    except TypeError as error:
        if "unexpected keyword argument" in str(error) or "missing" in str(error):
            raise PyconnectError(f"agent {name!r} ({conn_type}): {_option_error(error)}") from error
        raise
    except PyconnectError as error:
        if str(error).startswith("agent "):
            raise
        raise type(error)(f"agent {name!r} ({conn_type}): {error}") from error


def _option_error(error: TypeError) -> str:
    text = str(error)
    if "unexpected keyword argument" in text:
        option = text.rsplit("argument", 1)[1].strip()
        return f"unknown option {option} for this kind"
    return text.split("() ", 1)[-1]
