"""Every option an agent takes, typed once (``AgentOptions``), and the error for a wrong one.

``add_agent``/``make_agent`` accept these keys as keywords or as one config dict (the design's
``make_agent(node, {'conn_name': ..., 'conn_type': ...})``). Which keys a kind uses is what its
class's keyword-only ``__init__`` lists; ``agent_factory`` checks every given key against it, so
a typo or an option the kind does not use is an ``OptionError`` (a ``TypeError``) naming it,
never ignored. Type checkers check the keys and their types through ``Unpack[AgentOptions]``.
A new option goes into its agent classes' ``__init__`` and here.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, TypedDict

from pyconnect.errors import PyconnectError

if TYPE_CHECKING:
    from collections.abc import Callable

    from rclpy.callback_groups import CallbackGroup
    from rclpy.qos import QoSProfile

    from pyconnect.codecs.base import Codec


class OptionError(PyconnectError, TypeError):
    """An agent option (or a ``CustomNode`` keyword) that is unknown, unused by the agent's
    kind, missing, or of a type or value the agent cannot use."""


class AgentOptions(TypedDict, total=False):
    """The keys of an agent config; which ones a kind uses is listed in its class."""

    conn_name: str
    conn_type: str
    agent_name: str | None
    data_interface: object
    encode_func: Callable[[Any, Any], Any] | None
    decode_func: Callable[[Any], Any] | None
    codec: Codec | None
    response_func: Callable[..., Any] | None
    accepted_func: Callable[[bool], Any] | None
    feedback_func: Callable[[Any], Any] | None
    do_log_msg: bool
    qos: QoSProfile | str | int | None
    time_period: float | None
    frame_id: str
    only_if_subscribed: bool
    stamped: bool
    raw: bool | None
    timeout: float | None
    result_timeout: float
    result_cache_seconds: float
    callback_group: CallbackGroup | None
    transport: str | None
