"""What a peer's ``add_agent`` takes: the agent kinds, their options as ``CustomNode``'s (their
values checked as ``CustomNode`` checks them), and ``qos=`` read as a depth (the one QoS
setting a peer's zenoh topics have)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from pyconnect.errors import PyconnectError
from pyconnect.ros.agent_options import AgentOptions, OptionError
from pyconnect.ros.option_checks import KNOWN_OPTIONS, options_of
from pyconnect.ros.option_values import check_option_values
from pyconnect.transport.action_client import ActionClientAgent
from pyconnect.transport.action_server import ActionServerAgent
from pyconnect.transport.peer_agent import DEFAULT_DEPTH, PeerAgent, TimerAgent
from pyconnect.transport.service_agents import ServiceClientAgent, ServiceServerAgent
from pyconnect.transport.topic_publisher import PublisherAgent
from pyconnect.transport.topic_subscriber import SubscriberAgent

__all__ = [
    "KEEP_ALL_DEPTH",
    "NOT_ON_A_PEER",
    "PEER_AGENT_CLASSES",
    "PEER_OPTIONS",
    "TAKES_QOS",
    "PeerAgentOptions",
    "accepted_options",
    "check_values",
    "depth_from_qos",
]

PEER_AGENT_CLASSES: dict[str, type[PeerAgent]] = {
    "sub": SubscriberAgent,
    "pub": PublisherAgent,
    "service_client": ServiceClientAgent,
    "service_server": ServiceServerAgent,
    "timer": TimerAgent,
    "action_client": ActionClientAgent,
    "action_server": ActionServerAgent,
}


class PeerAgentOptions(AgentOptions, total=False):
    """``CustomNode``'s agent options, and what only a peer's topics and services take."""

    depth: int


TAKES_QOS = frozenset({"sub", "pub"})
"""The kinds that take ``qos=`` (as on ``CustomNode``): a peer reads its depth."""


def accepted_options(agent_class: type[PeerAgent]) -> frozenset[str]:
    accepted = options_of(agent_class)[0]
    return accepted | {"qos"} if agent_class.conn_type in TAKES_QOS else accepted


PEER_OPTIONS = frozenset().union(*map(accepted_options, PEER_AGENT_CLASSES.values()))
"""Every option some kind takes on a peer."""
_WHYNOT_ON_A_PEER = {
    "do_log_msg": "a peer writes no message logs (log from response_func)",
    "callback_group": "a peer has no rclpy executor (each agent has a thread of its own)",
    "transport": "a peer is on zenoh already",
}
NOT_ON_A_PEER: dict[str, str] = {
    option: "is not available on a peer"
    + (f": {_WHYNOT_ON_A_PEER[option]}" if option in _WHYNOT_ON_A_PEER else "")
    for option in sorted(KNOWN_OPTIONS - PEER_OPTIONS - {"conn_type"})
}
"""``CustomNode`` options no kind takes on a peer, and what ``OptionError`` says of them."""


def check_values(conn_type: str, given: Mapping[str, Any], where: str) -> None:
    """Refuse option values of the wrong type as ``CustomNode`` does
    (pyconnect.ros.option_values): ``OptionError`` starts with ``where`` and names the option."""
    check_option_values(conn_type, given, where)


KEEP_ALL_DEPTH = 1000
"""The depth of a keep-all ``qos=`` (a peer's subscription keeps a bounded ring), as a bridge's."""
_NAMED_DEPTHS = {"default": DEFAULT_DEPTH, "sensor_data": 5}
"""The depths of the profiles ``CustomNode`` names (pyconnect.ros.qos: rclpy's default and
sensor-data profiles)."""


def depth_from_qos(qos: object, where: str) -> int | None:
    """The depth a peer's sub or pub uses for ``CustomNode``'s ``qos=`` (None: the default).

    An int is the depth; ``'default'`` is 10 and ``'sensor_data'`` 5; a ``QoSProfile`` (or any
    object with ``depth``, ``history`` and ``durability``) gives its depth, or ``KEEP_ALL_DEPTH``
    for keep-all. Reliability is not used: a peer always sends as rmw_zenoh's reliable
    keep-last publishers do (reliable links, dropping on congestion), which a best-effort reader
    also accepts; deadline, lifespan and liveliness are not used either. Transient-local
    durability (``'latched'``) raises ``OptionError``: a peer keeps no cache for late joiners.
    """
    expected = "expected a QoSProfile, a name or a depth"
    if qos is None:
        return None
    if isinstance(qos, bool):
        raise PyconnectError(f"{where}: qos: {expected}, got {qos!r}")
    if isinstance(qos, int):
        depth = qos
    elif isinstance(qos, str):
        if qos == "latched":
            raise OptionError(f"{where}: qos {qos!r} {_NO_TRANSIENT_LOCAL}")
        if qos not in _NAMED_DEPTHS:
            names = ", ".join(repr(name) for name in [*_NAMED_DEPTHS, "latched"])
            raise PyconnectError(
                f"{where}: qos: unknown profile {qos!r}; expected a QoSProfile or one of {names}"
            )
        depth = _NAMED_DEPTHS[qos]
    elif all(hasattr(qos, field) for field in ("depth", "history", "durability")):
        profile: Any = qos  # an rclpy QoSProfile, whose class a peer never imports
        if _policy(profile.durability) == "transient_local":
            raise OptionError(f"{where}: qos durability TRANSIENT_LOCAL {_NO_TRANSIENT_LOCAL}")
        depth = int(profile.depth)
        if _policy(profile.history) == "keep_all":
            depth = max(depth, KEEP_ALL_DEPTH)
    else:
        raise PyconnectError(f"{where}: qos: {expected}, got {type(qos).__name__}")
    if depth < 1:
        raise PyconnectError(f"{where}: qos: depth must be >= 1, got {depth!r}")
    return depth


_NO_TRANSIENT_LOCAL = (
    "cannot be honoured on a peer: it keeps no cache for late joiners (zenoh-python has no "
    "publication cache)"
)


def _policy(value: object) -> str:
    """A QoS policy's name in lower case (an rclpy enum member, or a plain string)."""
    return str(getattr(value, "name", value)).lower()
