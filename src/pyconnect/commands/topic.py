"""``pyconnect topic list|info|echo|hz|bw|pub``: ros2cli's topic verbs with natural values.

Names, flags and output lines follow ``ros2 topic`` so habits and scripts carry over; values are
pyconnect's natural values (an image is a one-line summary). Exit status: 0 done, 1 the command
could not do its work, 2 a bad command line, 130 on Ctrl-C.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import argparse
import time
from typing import TYPE_CHECKING, Any, TextIO

from pyconnect.commands.argument_types import nonnegative_seconds, positive_int
from pyconnect.commands.common import Parser
from pyconnect.commands.live_options import add_no_daemon, add_qos, add_spin_time, expand_name
from pyconnect.commands.topic_subscribe import (
    await_first,
    echo_field,
    no_message_reason,
    publisher_types,
    subscribe,
)

if TYPE_CHECKING:
    from pyconnect.commands.common import Subcommands
    from pyconnect.commands.topic_subscribe import Subscribed

__all__ = ["register"]

EXAMPLES = """examples:
  pyconnect topic list -t
  pyconnect topic info /chatter -v
  pyconnect topic type /chatter
  pyconnect topic echo /camera/image_raw --qos-profile sensor_data
  pyconnect topic echo /odom --field pose.pose.position --once --json
  pyconnect topic echo /joint_states --no-arr --qos-reliability best_effort
  pyconnect topic hz /imu/data
  pyconnect topic bw /camera/image_raw
  pyconnect topic pub /chatter std_msgs/msg/String "hello" --rate 10
  pyconnect topic pub /cmd_vel geometry_msgs/msg/Twist "[[0.2, 0, 0], [0, 0, 0.5]]" --once
  pyconnect topic pub /cmd_vel geometry_msgs/msg/Twist "{linear: {x: 0.2}}" --times 3
  pyconnect topic pub /goal geometry_msgs/msg/PoseStamped "{header: auto, pose: {}}" --once
"""


def register(commands: Subcommands) -> Subcommands:
    """Add ``topic`` and its verbs to the ``pyconnect`` subparsers."""
    topic = commands.add_parser(
        "topic",
        help="list, inspect, echo, measure and publish topics of a live ROS graph",
        description="Topics of a live ROS 2 graph, as `ros2 topic` shows them.",
        epilog=EXAMPLES,
    )
    verbs = topic.add_subparsers(dest="verb", required=True, parser_class=Parser)

    listing = verbs.add_parser("list", help="the topics of the graph", epilog=EXAMPLES)
    listing.add_argument("-t", "--show-types", action="store_true", help="show each type")
    listing.add_argument(
        "--include-hidden-topics",
        action="store_true",
        help="also topics with a part that starts with _",
    )
    add_spin_time(listing)
    add_no_daemon(listing)
    listing.set_defaults(run=_list)

    info = verbs.add_parser(
        "info", help="type, publishers and subscriptions of a topic", epilog=EXAMPLES
    )
    info.add_argument("topic", type=expand_name)
    info.add_argument("-v", "--verbose", action="store_true", help="each endpoint and its QoS")
    add_spin_time(info)
    add_no_daemon(info)
    info.set_defaults(run=_info)

    kind = verbs.add_parser("type", help="the type of a topic", epilog=EXAMPLES)
    kind.add_argument("topic", type=expand_name)
    add_spin_time(kind)
    add_no_daemon(kind)
    kind.set_defaults(run=_type)

    echo = verbs.add_parser("echo", help="print the natural values of a topic", epilog=EXAMPLES)
    echo.add_argument("topic", type=expand_name)
    echo.add_argument("message_type", nargs="?", help="the type (found on the graph if left out)")
    echo.add_argument("--json", action="store_true", help="one JSON value per line")
    echo.add_argument("--field", help="print only this field of each message (a.b.c)")
    echo.add_argument("--once", action="store_true", help="print one message and exit")
    echo.add_argument(
        "--no-arr",
        action="store_true",
        help="show messages by their fields, each array as its type and length (as ros2)",
    )
    add_qos(echo)
    add_no_daemon(echo)
    echo.add_argument(
        "--timeout",
        type=nonnegative_seconds,
        metavar="S",
        help="give up after S seconds without a message",
    )
    echo.set_defaults(run=_echo)

    hz = verbs.add_parser("hz", help="the rate at which a topic is published", epilog=EXAMPLES)
    hz.add_argument("topic", type=expand_name)
    hz.add_argument("message_type", nargs="?", help="the type (found on the graph if left out)")
    hz.add_argument(
        "-w",
        "--window",
        type=positive_int,
        default=10000,
        help="intervals to average (default 10000)",
    )
    add_qos(hz, default="sensor_data")
    hz.add_argument(
        "--timeout",
        type=nonnegative_seconds,
        metavar="S",
        help="give up after S seconds without a message",
    )
    hz.set_defaults(run=_hz)

    bw = verbs.add_parser("bw", help="the bandwidth a topic uses", epilog=EXAMPLES)
    bw.add_argument("topic", type=expand_name)
    bw.add_argument("message_type", nargs="?", help="the type (found on the graph if left out)")
    bw.add_argument(
        "-w", "--window", type=positive_int, default=100, help="messages to average (100)"
    )
    add_qos(bw, default="sensor_data")
    bw.add_argument(
        "--timeout",
        type=nonnegative_seconds,
        metavar="S",
        help="give up after S seconds without a message",
    )
    bw.set_defaults(run=_bw)

    from pyconnect.commands import topic_pub

    topic_pub.register(verbs, epilog=EXAMPLES)
    return verbs


def _hidden(name: str) -> bool:
    return any(part.startswith("_") for part in name.split("/"))


def _list(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from pyconnect.commands.graph import graph_session

    with graph_session("topic") as session:
        session.spin_for(args.spin_time)
        topics = session.node.get_topic_names_and_types()
    for name, types in sorted(topics):
        if _hidden(name) and not args.include_hidden_topics:
            continue
        print(f"{name} [{', '.join(types)}]" if args.show_types else name, file=out)
    return 0


def _info(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from pyconnect.commands.graph import (
        CommandFailed,
        endpoints_named,
        graph_session,
        report_failure,
    )

    with graph_session("topic") as session:
        # Discovery goes on after the topic is first seen (more publishers, other processes):
        # counts read then were short. --spin-time is the time discovery is given, as for list.
        session.spin_for(args.spin_time)
        node = session.node
        if not dict(node.get_topic_names_and_types()).get(args.topic):
            return report_failure(CommandFailed(f"Unknown topic '{args.topic}'"), err)
        # The nodes of endpoints seen are on their way: at most another --spin-time for them.
        session.spin_until(lambda: endpoints_named(session, [args.topic]), args.spin_time)
        types = dict(node.get_topic_names_and_types())[args.topic]
        publishers = node.get_publishers_info_by_topic(args.topic)
        subscriptions = node.get_subscriptions_info_by_topic(args.topic)
    gap = "\n" if args.verbose else ""
    # ros2's line: the type, or the list of them when the endpoints disagree.
    print(f"Type: {types[0] if len(types) == 1 else types}{gap}", file=out)
    print(f"Publisher count: {len(publishers)}{gap}", file=out)
    if args.verbose:
        for endpoint in publishers:
            print(f"{endpoint}\n", file=out)
    print(f"Subscription count: {len(subscriptions)}{gap}", file=out)
    if args.verbose:
        for endpoint in subscriptions:
            print(f"{endpoint}\n", file=out)
    return 0


def _type(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from pyconnect.commands.graph import CommandFailed, graph_session, report_failure, topic_types

    with graph_session("topic") as session:
        try:
            # Found within --spin-time, then given time to settle: another process may add a type.
            types = topic_types(session, args.topic, timeout=args.spin_time)
        except CommandFailed:
            return report_failure(CommandFailed(f"Unknown topic '{args.topic}'"), err)
    for msg_type in types:
        print(msg_type, file=out)
    return 0


def _no_message(args: argparse.Namespace, subscribed: Subscribed, err: TextIO) -> int:
    """Exit status 1 with why nothing came on the topic within ``--timeout``."""
    from pyconnect.commands.graph import CommandFailed, report_failure

    published = publisher_types(subscribed.session, args.topic)
    reason = no_message_reason(args.topic, subscribed.msg_type, published, args.timeout)
    return report_failure(CommandFailed(reason), err)


def _left(args: argparse.Namespace, started: float) -> float | None:
    return None if args.timeout is None else args.timeout - (time.monotonic() - started)


def _echo(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from pyconnect.commands.graph import PROGRAM, report_failure
    from pyconnect.commands.live_values import shown_text
    from pyconnect.commands.value_text import abbreviated_fields
    from pyconnect.errors import PyconnectError

    received: list[Any] = []

    def on_message(msg: Any) -> None:
        received.append(msg)

    # --timeout bounds the whole wait for a first message, finding the type included.
    started = time.monotonic()
    try:
        subscribed = subscribe(args, "echo", on_message, raw=False, started=started)
    except PyconnectError as error:
        return report_failure(error, err)
    session, notes = subscribed.session, subscribed.notes
    said = 0

    def say_notes() -> None:
        nonlocal said
        for note in notes[said:]:
            print(f"{PROGRAM}: note: {note}", file=err, flush=True)
        said = len(notes)

    try:
        if not await_first(
            session,
            args.topic,
            subscribed.msg_type,
            arrived=lambda: bool(received),
            timeout=_left(args, started),
            err=err,
        ):
            say_notes()
            return _no_message(args, subscribed, err)
        while True:
            session.spin_until(lambda: bool(received) or len(notes) > said, None)
            say_notes()
            while received:
                # A wrong --field is the command line's fault: select_field ends the echo.
                shown = echo_field(received.pop(0), args.field)
                if args.no_arr and hasattr(shown, "get_fields_and_field_types"):
                    shown = abbreviated_fields(shown)
                text, problem = shown_text(shown, as_json=args.json)
                if problem is not None:
                    said_as = "printed as its fields" if text is not None else "skipped"
                    print(
                        f"{PROGRAM}: warning: [{args.topic}]: cannot decode a message "
                        f"({said_as}): {problem}",
                        file=err,
                        flush=True,
                    )
                if text is None:
                    continue
                print(text, file=out, flush=args.json)
                if not args.json:
                    print("---", file=out, flush=True)
                if args.once:
                    return 0
    except PyconnectError as error:
        return report_failure(error, err)
    finally:
        subscribed.close()


def _hz(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from pyconnect.commands.graph import report_failure
    from pyconnect.commands.topic_stats import RateWindow
    from pyconnect.errors import PyconnectError

    window = RateWindow(args.window)
    clock: list[Any] = []
    count = [0]

    def on_message(_data: bytes) -> None:
        count[0] += 1
        window.add(clock[0].now().nanoseconds)
        report = window.report()
        if report is not None:
            print(report, file=out, flush=True)

    started = time.monotonic()
    try:
        subscribed = subscribe(args, "hz", on_message, raw=True, started=started)
    except PyconnectError as error:
        return report_failure(error, err)
    session = subscribed.session
    clock.append(session.node.get_clock())
    try:
        # As echo: a topic that sends nothing (no publisher, another type) is said, and
        # --timeout gives up on it.
        if not await_first(
            session,
            args.topic,
            subscribed.msg_type,
            arrived=lambda: count[0] > 0,
            timeout=_left(args, started),
            err=err,
        ):
            return _no_message(args, subscribed, err)
        while True:
            session.spin_once(0.1)
    finally:
        subscribed.close()


def _bw(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from pyconnect.commands.graph import report_failure
    from pyconnect.commands.topic_stats import BandwidthWindow
    from pyconnect.errors import PyconnectError

    window = BandwidthWindow(args.window)
    count = [0]

    def on_message(data: bytes) -> None:
        count[0] += 1
        window.add(time.monotonic(), len(data))

    started = time.monotonic()
    try:
        subscribed = subscribe(args, "bw", on_message, raw=True, started=started)
    except PyconnectError as error:
        return report_failure(error, err)
    session = subscribed.session
    print(f"Subscribed to [{args.topic}]", file=out, flush=True)
    try:
        if not await_first(
            session,
            args.topic,
            subscribed.msg_type,
            arrived=lambda: count[0] > 0,
            timeout=_left(args, started),
            err=err,
        ):
            return _no_message(args, subscribed, err)
        next_report = time.monotonic() + 1.0
        while True:
            session.spin_once(max(0.0, min(0.1, next_report - time.monotonic())))
            if time.monotonic() >= next_report:
                next_report += 1.0
                report = window.report(time.monotonic())
                if report is not None:
                    print(report, file=out, flush=True)
    finally:
        subscribed.close()
