"""What a peer knows of an agent's interface without rclpy: names, RIHS01 hashes, wire codecs.

``data_interface`` is a type name (``'sensor_msgs/msg/Image'``, ``'std_srvs/srv/SetBool'``) or
an installed rclpy class (only its module path is read). Messages take the wire codec's hash;
services take the hash the generated index lists for the service type itself (rmw_zenoh puts
that hash, not the request's, in a service's key expression). An action is what rcl_action
builds of services and topics; its implicit services' hashes come from the index too.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass

from pyconnect.codecs import wire
from pyconnect.codecs.wire import WireCodec
from pyconnect.errors import CodecNotFoundError, PyconnectError
from pyconnect.typesys.names import parse_type_name


@dataclass(frozen=True)
class MessageInterface:
    type_name: str
    type_hash: str
    codec: WireCodec


@dataclass(frozen=True)
class ServiceInterface:
    type_name: str
    type_hash: str
    request: WireCodec
    response: WireCodec


@dataclass(frozen=True)
class ActionInterface:
    """An action's parts: rcl_action's three services and two topics, and the user's types."""

    type_name: str
    goal: WireCodec
    result: WireCodec
    feedback: WireCodec
    send_goal: ServiceInterface
    get_result: ServiceInterface
    cancel_goal: ServiceInterface
    feedback_message: MessageInterface
    status: MessageInterface


_KIND_WORDS = {"msg": "message", "srv": "service", "action": "action"}


def _full_name(data_interface: object, kind: str) -> str:
    if not isinstance(data_interface, (str, type)):
        raise PyconnectError(
            f"data_interface: expected a type name 'pkg/{kind}/Name' or an interface class, "
            f"got {type(data_interface).__name__}"
        )
    parsed = parse_type_name(data_interface)
    namespace = parsed.namespace or kind
    if namespace != kind:
        raise PyconnectError(
            f"{parsed.full(namespace)}: expected a {_KIND_WORDS[kind]} type, got a "
            f"{_KIND_WORDS.get(namespace, 'non-ROS')} type"
        )
    return parsed.full(namespace)


def message_interface(data_interface: object) -> MessageInterface:
    """Name, hash and wire codec of a message type."""
    name = _full_name(data_interface, "msg")
    codec = wire.wire_codec(name)
    return MessageInterface(codec.msg_type, codec.type_hash, codec)


def service_interface(data_interface: object) -> ServiceInterface:
    """Name, hash and the request/response wire codecs of a service type."""
    return _service_parts(_full_name(data_interface, "srv"))


def action_interface(data_interface: object) -> ActionInterface:
    """Every type an action's services and topics carry, with their hashes."""
    name = _full_name(data_interface, "action")
    feedback_message = wire.wire_codec(f"{name}_FeedbackMessage")
    status = wire.wire_codec("action_msgs/msg/GoalStatusArray")
    return ActionInterface(
        type_name=name,
        goal=wire.wire_codec(f"{name}_Goal"),
        result=wire.wire_codec(f"{name}_Result"),
        feedback=wire.wire_codec(f"{name}_Feedback"),
        send_goal=_service_parts(f"{name}_SendGoal"),
        get_result=_service_parts(f"{name}_GetResult"),
        cancel_goal=_service_parts("action_msgs/srv/CancelGoal"),
        feedback_message=MessageInterface(
            feedback_message.msg_type, feedback_message.type_hash, feedback_message
        ),
        status=MessageInterface(status.msg_type, status.type_hash, status),
    )


def _service_parts(name: str) -> ServiceInterface:
    request = wire.wire_codec(f"{name}_Request")
    response = wire.wire_codec(f"{name}_Response")
    return ServiceInterface(name, _indexed_hash(name), request, response)


def _indexed_hash(full_name: str) -> str:
    package = full_name.split("/", 1)[0]
    try:
        index = importlib.import_module(f"pyconnect_generated.{package}.index")
    except ModuleNotFoundError:
        index = None
    hashes: dict[str, str] = getattr(index, "TYPE_HASHES", {})
    found = hashes.get(full_name)
    if found is None:
        raise CodecNotFoundError(
            f"{full_name}: no RIHS01 hash for this service (generate its package with "
            "`codecgen build`)"
        )
    return found
