"""``pyconnect topic pub``: publish a VALUE (YAML/JSON) once, N times or until Ctrl-C.

Follows ``ros2 topic pub``: ``--times 0`` (the default) publishes until Ctrl-C, ``--once`` and
``--times`` wait for a subscription first unless ``-w`` says otherwise, and ``now``/``auto``
stamps are taken again at every publish.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import argparse
import time
from typing import TYPE_CHECKING, TextIO

from pyconnect.commands.argument_types import (
    nonnegative_int,
    nonnegative_seconds,
    positive_float,
)

if TYPE_CHECKING:
    from pyconnect.commands.common import Subcommands

__all__ = ["register"]


def register(verbs: Subcommands, *, epilog: str) -> None:
    """Add ``pub`` to the ``topic`` verbs."""
    from pyconnect.commands.live_options import add_qos, expand_name

    pub = verbs.add_parser(
        "pub",
        help="publish a value (YAML/JSON: the message's fields or its natural value)",
        epilog=epilog,
    )
    pub.add_argument("topic", type=expand_name)
    pub.add_argument("message_type", help="e.g. std_msgs/msg/String")
    pub.add_argument(
        "value",
        nargs="?",
        default="{}",
        help="YAML or JSON (default {}); `now` in a Time field and `auto` for a Header stamp "
        "each message with the current time",
    )
    pub.add_argument("-r", "--rate", type=positive_float, default=1.0, help="Hz (default 1)")
    pub.add_argument("-1", "--once", action="store_true", help="publish one message and exit")
    pub.add_argument(
        "-t",
        "--times",
        type=nonnegative_int,
        default=0,
        help="publish this many messages and exit (default 0: until Ctrl-C)",
    )
    pub.add_argument(
        "-w",
        "--wait-matching-subscriptions",
        type=nonnegative_int,
        help="wait for this many subscriptions first (default 1 with --once or --times N, else 0)",
    )
    pub.add_argument(
        "--timeout",
        type=nonnegative_seconds,
        metavar="S",
        help="give up waiting for subscriptions after S s",
    )
    add_qos(pub, default="default")
    pub.set_defaults(run=_pub)


def _pub(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from rclpy.impl.implementation_singleton import rclpy_implementation

    from pyconnect.commands.graph import (
        CommandFailed,
        endpoint_failure,
        graph_session,
        message_class,
        report_failure,
    )
    from pyconnect.commands.live_qos import requested_qos
    from pyconnect.commands.live_values import shown_line
    from pyconnect.commands.value_input import message_template
    from pyconnect.errors import PyconnectError
    from pyconnect.ros.qos import DEFAULT

    # ros2cli's meaning: --times 0 (the default) publishes until Ctrl-C.
    times = 1 if args.once else (args.times or None)
    wait_for = args.wait_matching_subscriptions
    if wait_for is None:
        wait_for = 1 if times is not None else 0
    try:
        msg_class = message_class(args.message_type)
        template = message_template(args.value, msg_class)
        qos = requested_qos(args, DEFAULT)  # `--qos-durability transient_local`: latched
    except PyconnectError as error:
        return report_failure(error, err)
    with graph_session("pub") as session:
        try:
            publisher = session.node.create_publisher(msg_class, args.topic, qos)
        except rclpy_implementation.RCLError as error:
            return report_failure(endpoint_failure(error, f"publish on {args.topic}"), err)
        if wait_for > 0:
            print(f"Waiting for at least {wait_for} matching subscription(s)...", file=out)
            if not session.spin_until(
                lambda: publisher.get_subscription_count() >= wait_for, args.timeout
            ):
                return report_failure(
                    CommandFailed(f"no {wait_for} matching subscription(s) on {args.topic}"), err
                )
        print("publisher: beginning loop", file=out)
        shown: str | None = None
        count = 0
        period = 1.0 / args.rate
        next_time = time.monotonic()
        while times is None or count < times:
            message = template.stamped()  # `now` / `auto` stamps: the time of this publish
            publisher.publish(message)
            count += 1
            if shown is None or template.now_paths:
                shown = shown_line(message, err)
            print(f"publishing #{count}: {shown}", file=out, flush=True)
            if times is not None and count >= times:
                break
            next_time += period
            session.spin_for(max(0.0, next_time - time.monotonic()))
        # Reliable subscriptions acknowledge in the background: wait for them before leaving.
        from rclpy.duration import Duration

        publisher.wait_for_all_acked(Duration(seconds=2))
    return 0
