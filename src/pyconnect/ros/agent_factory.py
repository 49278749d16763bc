"""``make_agent`` and ``AGENT_CLASS_DICT``: the one place that maps ``conn_type`` to an agent class.

New agent kinds register here: ``AGENT_CLASS_DICT['my_kind'] = MyAgent`` (a ``NodeAgent``
subclass whose keyword-only ``__init__`` options are the config keys it uses).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from rclpy.callback_groups import CallbackGroup
from rclpy.exceptions import NameValidationException
from rclpy.expand_topic_name import expand_topic_name
from rclpy.validate_full_topic_name import validate_full_topic_name

from pyconnect.errors import PyconnectError
from pyconnect.ros.action_client_agent import ActionClientAgent
from pyconnect.ros.action_server_agent import ActionServerAgent
from pyconnect.ros.agent_host import AgentHost
from pyconnect.ros.agent_options import AgentOptions, OptionError
from pyconnect.ros.node_agent import NodeAgent
from pyconnect.ros.option_checks import (
    check_options,
    options_of,
    plain_option_problem,
    shared_options,
)
from pyconnect.ros.option_values import check_option_values
from pyconnect.ros.publisher_agent import PublisherAgent
from pyconnect.ros.service_agents import ServiceClientAgent, ServiceServerAgent
from pyconnect.ros.subscriber_agent import SubscriberAgent
from pyconnect.ros.timer_agent import TimerAgent

if TYPE_CHECKING:
    from typing_extensions import Unpack

AGENT_CLASS_DICT: dict[str, type[NodeAgent]] = {
    "sub": SubscriberAgent,
    "pub": PublisherAgent,
    "service_client": ServiceClientAgent,
    "service_server": ServiceServerAgent,
    "action_client": ActionClientAgent,
    "action_server": ActionServerAgent,
    "timer": TimerAgent,
}

__all__ = ["AGENT_CLASS_DICT", "build_agent", "make_agent", "options_of", "shared_options_for"]


def make_agent(
    node: AgentHost,
    config: Mapping[str, Any] | None = None,
    /,
    **options: Unpack[AgentOptions],
) -> NodeAgent:
    """Make the agent a config describes on ``node``: a dict, keywords, or both (keywords win).

    ``make_agent(node, {'conn_name': 'chatter', 'conn_type': 'pub', ...})`` or
    ``make_agent(node, conn_name='chatter', conn_type='pub', ...)``. On a ``CustomNode`` (any
    host with ``add_agent``) it is ``node.add_agent(...)``: the agent is ``node.agents[name]``,
    ``wait_until_connected`` waits for it and shutdown closes it. An unknown ``conn_type``
    raises ``PyconnectError``; an unknown, unused or missing option raises ``OptionError`` (a
    ``TypeError``) naming it.
    """
    add_agent = getattr(node, "add_agent", None)
    if callable(add_agent):
        agent: NodeAgent = add_agent(config, **options)
        return agent
    return build_agent(node, {**(config or {}), **options})


def build_agent(node: AgentHost, given: Mapping[str, Any]) -> NodeAgent:
    """The agent ``given`` (a config's options) describes, built on ``node`` (not registered
    in ``node.agents``: ``CustomNode.add_agent`` does that)."""
    given = dict(given)
    conn_name = given.pop("conn_name", None)
    conn_type = given.pop("conn_type", None)
    agent_name = given.pop("agent_name", None)
    if not isinstance(conn_name, str) or not conn_name:
        raise OptionError(f"agent config: conn_name must be a non-empty str, got {conn_name!r}")
    problem = plain_option_problem("agent_name", agent_name)
    if problem is not None:  # before it names the agent: 5 became the key in node.agents
        raise OptionError(f"agent {conn_name!r}: {problem}")
    name = agent_name or conn_name
    if conn_type is None:
        raise OptionError(f"agent {name!r}: missing option 'conn_type'")
    if not isinstance(conn_type, str):  # a list made AGENT_CLASS_DICT raise "unhashable"
        raise OptionError(f"agent {name!r}: conn_type: expected one of {_KINDS}, got {conn_type!r}")
    transport = given.pop("transport", None)
    if transport is not None:  # a bridge to non-ROS peers (issue 13): its own module decides
        if transport != "zenoh":  # before the import, which needs the zenoh extra
            raise PyconnectError(
                f"agent {name!r}: unknown transport {transport!r}; expected 'zenoh'"
            )
        try:
            from pyconnect.ros.zenoh_bridge import make_bridge_agent
        except ModuleNotFoundError as error:
            missing = (error.name or "").split(".")[0]
            if missing not in _ZENOH_EXTRA:  # the extra's packages; anything else is a bug
                raise
            raise OptionError(
                f"agent {name!r} ({conn_type}): transport='zenoh' needs {_ZENOH_EXTRA[missing]}: "
                "pip install 'pyconnect-ros[zenoh]'"
            ) from error

        _check_values(None, given, f"agent {name!r} ({conn_type})")

        return make_bridge_agent(
            node,
            transport=transport,
            conn_name=conn_name,
            conn_type=conn_type,
            agent_name=agent_name,
            options=given,
        )
    agent_class = AGENT_CLASS_DICT.get(conn_type)
    if agent_class is None:
        raise PyconnectError(
            f"agent {name!r}: unknown conn_type {conn_type!r}; expected one of {_KINDS}"
        )
    _check_options(agent_class, given, f"agent {name!r} ({conn_type})")
    _check_values(agent_class, given, f"agent {name!r} ({conn_type})")
    if not issubclass(agent_class, TimerAgent):  # a timer's conn_name names no ROS entity
        problem = _name_problem(node, conn_name, conn_type)
        if problem is not None:
            raise OptionError(f"agent {name!r} ({conn_type}): {problem}")
    try:
        return agent_class(node, conn_name=conn_name, agent_name=agent_name, **given)
    except PyconnectError as error:
        if str(error).startswith("agent "):
            raise
        raise type(error)(f"agent {name!r} ({conn_type}): {error}") from error
    except NameValidationException as error:  # rclpy's words name no agent
        raise OptionError(f"agent {name!r} ({conn_type}): {error}") from error


def shared_options_for(conn_type: object, shared: Mapping[str, Any]) -> dict[str, Any]:
    """The shared options (``add_agents(configs, **shared)``) a kind uses: shared options are
    defaults, so ``do_log_msg=True`` shared by subs and a timer skips the timer. Unknown names
    are kept, so they still raise."""
    agent_class = AGENT_CLASS_DICT.get(conn_type) if isinstance(conn_type, str) else None
    accepted = None if agent_class is None else options_of(agent_class)[0]
    return shared_options(accepted, shared)


def _check_options(agent_class: type[NodeAgent], given: Mapping[str, Any], where: str) -> None:
    check_options(agent_class, given, where, kind=agent_class.conn_type or agent_class.__name__)


_KINDS = ", ".join(repr(kind) for kind in AGENT_CLASS_DICT)
_ZENOH_EXTRA = {"zenoh": "eclipse-zenoh", "xxhash": "xxhash"}
"""The zenoh extra's modules and the packages that bring them."""


def _check_values(
    agent_class: type[NodeAgent] | None, given: Mapping[str, Any], where: str
) -> None:
    """Refuse option values of the wrong type now (pyconnect.ros.option_values), and a wrong
    callback group, which failed inside rclpy in its own words."""
    check_option_values(_KIND_OF_CLASS.get(agent_class), given, where)
    group = given.get("callback_group")
    if group is not None and not isinstance(group, CallbackGroup):
        if isinstance(group, type) and issubclass(group, CallbackGroup):
            actual = f"the class {group.__name__}; did you mean {group.__name__}()?"
        else:
            actual = repr(group)
        raise OptionError(
            f"{where}: callback_group: expected an rclpy CallbackGroup (e.g. "
            f"ReentrantCallbackGroup()), got {actual}"
        )


_KIND_OF_CLASS: dict[type[NodeAgent] | None, str] = {
    TimerAgent: "timer",
    PublisherAgent: "pub",
    SubscriberAgent: "sub",
    ServiceServerAgent: "service_server",
    ActionServerAgent: "action_server",
    ActionClientAgent: "action_client",
}
"""The built-in kinds by class, whose handler shapes are checked. Exactly these: a subclass
registered in AGENT_CLASS_DICT may call its handlers otherwise (a sub passing a count too)."""


def _name_problem(node: AgentHost, conn_name: object, conn_type: str) -> str | None:
    """What rcl finds wrong with ``conn_name`` as a name of this node, or None. Checked before
    the agent is made: rclpy's action classes and graph queries raised their own RCLError or
    ValueError, naming no agent (and half made an action client)."""
    if not isinstance(conn_name, str):
        return f"conn_name: expected str, got {type(conn_name).__name__}"
    ros_node = node.ros_node
    try:
        expanded = expand_topic_name(conn_name, ros_node.get_name(), ros_node.get_namespace())
        validate_full_topic_name(expanded, is_service=conn_type.startswith("service"))
    except (NameValidationException, ValueError) as error:
        return str(error)
    return None
