"""How ``topic echo|hz|bw`` subscribe: the topic's type and QoS from the graph, then its first
message awaited (pyconnect.commands.topic runs the verbs).

The type is the one given or the topic's only type (a topic of several types wants it given);
both are read once discovery has settled (pyconnect.commands.graph.settle), since processes are
discovered one by one, and the types are read again just before subscribing. echo's QoS follows
the publishers, late ones too (pyconnect.commands.live_qos), waited for within ``--timeout``, so
a latched or best-effort publisher is heard; a topic published as another type is said once
while waiting.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from contextlib import ExitStack
from typing import Any, TextIO

_DOING = {"echo": "echo", "hz": "measure the rate of", "bw": "measure the bandwidth of"}


class Subscribed:
    """A graph session subscribed to a topic; ``close()`` ends the subscription and session."""

    def __init__(self, stack: ExitStack, session: Any, msg_type: str, notes: list[str]) -> None:
        self._stack = stack
        self.session = session
        self.msg_type = msg_type
        self.notes = notes
        """What a subscription following its publishers said each time it changed its QoS."""

    def close(self) -> None:
        self._stack.close()


def _one_type(verb: str, topic: str, types: list[str]) -> str:
    if len(types) > 1:
        # A subscription takes one type: the other publishers would go unheard.
        from pyconnect.commands.graph import CommandFailed

        raise CommandFailed(
            f"cannot {_DOING[verb]} {topic}: it has more than one type "
            f"({', '.join(types)}); give the type"
        )
    return types[0]


def _await_publishers(session: Any, topic: str, left: Callable[[], float | None]) -> None:
    """Spin until ``topic`` has a publisher and discovery has settled, within ``left()`` s.

    echo's QoS is matched to the publishers: chosen before they are discovered it is reliable
    and volatile, which misses a latched message and hears no best-effort publisher. With no
    publisher in time, that default it is."""
    from pyconnect.commands.graph import settle, topic_endpoints

    node = session.node
    if not session.spin_until(lambda: bool(node.get_publishers_info_by_topic(topic)), left()):
        return
    remaining = left()
    timeout = None if remaining is None else max(0.0, remaining)
    settle(session, lambda: topic_endpoints(session, topic), timeout=timeout)


def subscribe(
    args: argparse.Namespace, verb: str, on_message: Any, *, raw: bool, started: float
) -> Subscribed:
    """A session subscribed to ``args.topic``, and the type it expects; the caller spins it.

    ``--timeout`` bounds the waits here from ``started`` (monotonic) on."""
    from rclpy.impl.implementation_singleton import rclpy_implementation
    from rclpy.logging import LoggingSeverity

    from pyconnect.commands.graph import (
        endpoint_failure,
        graph_session,
        message_class,
        topic_types,
    )
    from pyconnect.commands.live_qos import EchoSubscription, follows_publishers, requested_qos
    from pyconnect.ros.interfaces import interface_name
    from pyconnect.ros.qos import SENSOR_DATA, matching_qos

    def left() -> float | None:
        return None if args.timeout is None else args.timeout - (time.monotonic() - started)

    stack = ExitStack()
    session = stack.enter_context(graph_session(verb))
    try:
        node = session.node
        topic = args.topic
        msg_type = args.message_type
        if not msg_type:
            msg_type = _one_type(verb, topic, topic_types(session, topic, timeout=left()))
        elif verb == "echo" and args.qos_profile is None:
            _await_publishers(session, topic, left)
        msg_class = message_class(msg_type)
        if not args.message_type:
            # Discovery went on while the type's module was imported.
            _one_type(verb, topic, dict(node.get_topic_names_and_types()).get(topic, [msg_type]))
        notes: list[str] = []
        try:
            if verb == "echo" and follows_publishers(args):
                # A switch of its QoS is said on stderr by the echo (Subscribed.notes), in
                # pyconnect's words; rcl's log line would say it a second time.
                node.get_logger().set_level(LoggingSeverity.WARN)
                follower = EchoSubscription(
                    node, msg_class=msg_class, topic=topic, callback=on_message, raw=raw, args=args
                )
                stack.callback(follower.close)  # before the session: the reader needs its node
                notes = follower.notes
            else:
                publishers = node.get_publishers_info_by_topic(topic)
                default = matching_qos(publishers, depth=10) if verb == "echo" else SENSOR_DATA
                qos = requested_qos(args, default)
                node.create_subscription(msg_class, topic, on_message, qos, raw=raw)
        except rclpy_implementation.RCLError as error:
            raise endpoint_failure(error, f"subscribe to {topic}") from None
    except BaseException:
        stack.close()
        raise
    return Subscribed(stack, session, interface_name(msg_class), notes)


def no_message_reason(topic: str, msg_type: str, published: list[str], timeout: float) -> str:
    """Why ``echo --timeout`` got nothing: ``published`` holds the type of each publisher."""
    said = f"no message on [{topic}] within {timeout:g} s"
    if not published:
        return f"{said}: it has no publishers"
    others = ", ".join(sorted(set(published) - {msg_type}))
    if msg_type not in published:
        return f"{said}: it is published as {others}, not {msg_type}"
    count = published.count(msg_type)
    also = f" (others publish {others})" if others else ""
    return f"{said} from its {count} publisher(s) of {msg_type}{also}"


def echo_field(msg: Any, field: str | None) -> Any:
    """What ``echo --field`` shows of ``msg``: the field as ``bag echo --field`` and ``ros2
    topic echo --field`` show it, from the message's dict.

    A message field is its dict (``pose.pose.position`` is ``{x, y, z}``, as in the whole
    message's dict: Point's natural tuple dropped the names), but an image, which stays an
    image (its summary); any other field is taken from its message's dict: rclpy holds a
    ``byte`` as ``b'\\x00'`` and a ``uint8[]`` as an ``array.array``, where the dict has ``0``
    and ``bytes``.
    """
    from pyconnect import codecs
    from pyconnect.commands.live_values import IMAGE_TYPES, select_field

    value = select_field(msg, field)  # also says which part of a wrong --field is missing
    if not field:
        return value
    if hasattr(value, "get_fields_and_field_types"):
        return value if type(value).__name__ in IMAGE_TYPES else codecs.to_dict(value)
    parent_path, _, name = field.rpartition(".")
    fields = codecs.to_dict(select_field(msg, parent_path or None))
    return fields.get(name, value)


def publisher_types(session: Any, topic: str) -> list[str]:
    return [str(p.topic_type) for p in session.node.get_publishers_info_by_topic(topic)]


def await_first(
    session: Any,
    topic: str,
    msg_type: str,
    *,
    arrived: Callable[[], bool],
    timeout: float | None,
    err: TextIO,
) -> bool:
    """Spin until ``arrived()``: False when ``timeout`` s pass first (None: wait for ever).

    A topic published as another type will never deliver: without a timeout that is said once,
    as the wait may be long (``ros2 topic echo`` waits silently)."""
    from pyconnect.commands.graph import PROGRAM

    warned = False

    def done() -> bool:
        nonlocal warned
        if arrived():
            return True
        if timeout is None and not warned:
            published = publisher_types(session, topic)
            if published and msg_type not in published:
                others = ", ".join(sorted(set(published)))
                print(
                    f"{PROGRAM}: warning: [{topic}] is published as {others}, not {msg_type}: "
                    f"waiting for a publisher of {msg_type}",
                    file=err,
                    flush=True,
                )
                warned = True
        return False

    result: bool = session.spin_until(done, timeout)
    return result
