"""``pyconnect bag play``: republish a bag's messages with their original timing.

Each message is published (as its stored CDR bytes) when ``(log time - first log time -
start offset) / rate`` seconds have passed since playing began. Each topic is offered with the
QoS its publishers had when recorded (``offered_qos_profiles`` in the bag: reliable unless they
were all best effort; transient local when they all were), else the default profile.
``--clock`` also publishes the bag's time on ``/clock`` (before each message and every 25 ms) for
nodes with ``use_sim_time``. At the end it prints how late messages were published against their
schedule (mean and max), the timing error. Ctrl-C stops playing (exit 0). A topic whose type is
not installed is left out with a warning, as ``ros2 bag play`` does; a damaged bag plays all
that can be read, then its damage is reported and the exit status is 1 (``--ignore-damage``: 0).
A ``--topics`` name not in the bag is an error (exit status 1); when there is nothing to play
(``--start-offset`` past the end), playing ends at once with a warning, ``--loop`` or not.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import argparse
import time
from typing import TYPE_CHECKING, Any, TextIO

from pyconnect.commands.argument_types import nonnegative_seconds, positive_float
from pyconnect.commands.bag_damage import IGNORE_DAMAGE_HELP, damage_status
from pyconnect.errors import PyconnectError

if TYPE_CHECKING:
    from pyconnect.commands.common import Subcommands

__all__ = ["offered_qos", "register"]

EXAMPLES = """examples:
  pyconnect bag play run1
  pyconnect bag play run1 --rate 2 --loop --topics /camera/image_raw /joint_states
  pyconnect bag play run1 --clock --start-offset 12.5
"""

CLOCK_PERIOD = 0.025


def register(actions: Subcommands) -> None:
    """Add ``play`` to the ``bag`` actions."""
    play = actions.add_parser(
        "play",
        help="republish a bag's messages with their original timing",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    play.add_argument("path", help="bag directory, .mcap or .db3 file")
    play.add_argument(
        "-r", "--rate", type=positive_float, default=1.0, help="speed factor (default 1)"
    )
    play.add_argument("-l", "--loop", action="store_true", help="play again and again")
    play.add_argument("--topics", nargs="+", help="only these topics")
    play.add_argument("--clock", action="store_true", help="publish the bag's time on /clock")
    play.add_argument(
        "--start-offset",
        type=nonnegative_seconds,
        default=0.0,
        metavar="S",
        help="skip the first S seconds",
    )
    play.add_argument(
        "-d",
        "--delay",
        type=nonnegative_seconds,
        default=0.0,
        metavar="S",
        help="wait S seconds before playing",
    )
    play.add_argument("--ignore-damage", action="store_true", help=IGNORE_DAMAGE_HELP)
    play.set_defaults(run=_play)


def offered_qos(text: str) -> Any:
    """The QoS to offer a topic, from the bag's ``offered_qos_profiles`` YAML."""
    import yaml
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    try:
        profiles = yaml.safe_load(text) if text else None
    except (yaml.YAMLError, RecursionError):  # a file's text: 3000 '[' overflow the parser
        profiles = None
    if not isinstance(profiles, list) or not profiles:
        return QoSProfile(depth=10)

    def policy(profile: Any, key: str) -> str:
        value = profile.get(key) if isinstance(profile, dict) else None
        names = {
            "reliability": {1: "reliable", 2: "best_effort"},
            "durability": {1: "transient_local", 2: "volatile"},
        }[key]
        return (
            names.get(value, str(value).lower()) if isinstance(value, int) else str(value).lower()
        )

    best_effort = all(policy(p, "reliability") == "best_effort" for p in profiles)
    latched = all(policy(p, "durability") == "transient_local" for p in profiles)
    return QoSProfile(
        depth=10,
        reliability=ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
    )


def _play(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from pyconnect.commands.graph import CommandFailed, graph_session, report_failure

    try:
        with graph_session("play") as session:
            late, damage, summary = _play_all(args, session, out, err)
    except KeyboardInterrupt:  # Ctrl-C ends playing: a success
        return 0
    except CommandFailed as failure:
        return report_failure(failure, err)
    if late.count:
        print(
            f"Played {late.count} message(s); timing error: mean {late.mean * 1e3:.3f} ms, "
            f"max {late.worst * 1e3:.3f} ms",
            file=out,
        )
    return damage_status(damage, summary, args, err)


def _play_all(
    args: argparse.Namespace, session: Any, out: TextIO, err: TextIO
) -> tuple[Lateness, list[Any], str]:
    """Play the bag; the timing errors, and the damage the bag showed with its summary."""
    from rosgraph_msgs.msg import Clock  # type: ignore[import-untyped]

    from pyconnect.commands.graph import CommandFailed
    from pyconnect.record.bag_reader import bag_info, open_bag
    from pyconnect.ros.interfaces import interface_class

    info = bag_info(args.path)
    if args.topics is not None:
        names = [t.name for t in info.topics]
        unknown = [name for name in dict.fromkeys(args.topics) if name not in names]
        if unknown:  # as `bag echo --topic`: a typo must not play nothing and exit 0
            raise CommandFailed(
                f"{info.path}: no topic {', '.join(unknown)} in this bag "
                f"(topics: {', '.join(names) or 'none'})"
            )
    topics = [t for t in info.topics if args.topics is None or t.name in args.topics]
    publishers: dict[str, Any] = {}
    for topic in topics:
        try:
            msg_class = interface_class(topic.msg_type, kind="msg")
        except PyconnectError as error:
            # As ros2 bag play: the other topics still play (tf2_msgs is not in the wheels).
            print(
                f"pyconnect: warning: not playing {topic.name}: {error} "
                "(codecgen build --compile builds a type from its definition)",
                file=err,
            )
            continue
        publishers[topic.name] = session.node.create_publisher(
            msg_class, topic.name, offered_qos(topic.offered_qos_profiles)
        )
    clock = session.node.create_publisher(Clock, "/clock", 10) if args.clock else None
    start_ns = (info.start_ns or 0) + round(args.start_offset * 1e9)
    if topics and not publishers:
        raise CommandFailed(f"{info.path}: no topic to play: no type of the bag is installed")
    late = Lateness()
    session.spin_for(args.delay)  # time for subscribers to discover the new publishers
    print(f"Playing {info.path} ({len(publishers)} topic(s))", file=out, flush=True)
    while True:
        began = time.monotonic()
        last_clock = 0.0
        played = 0
        with open_bag(args.path, topics=list(publishers), raw=True, start_ns=start_ns) as bag:
            for message in bag:
                played += 1
                due = began + (message.log_time_ns - start_ns) / 1e9 / args.rate
                while True:
                    now = time.monotonic()
                    if clock is not None and now - last_clock >= CLOCK_PERIOD:
                        elapsed_ns = round((now - began) * args.rate * 1e9)
                        clock.publish(_clock(min(start_ns + elapsed_ns, message.log_time_ns)))
                        last_clock = now
                    if now >= due:
                        break
                    time.sleep(min(due - now, CLOCK_PERIOD))
                if clock is not None:
                    clock.publish(_clock(message.log_time_ns))
                publishers[message.topic].publish(bytes(message.value))
                late.add(time.monotonic() - due)
            damage = bag.damage
            summary = bag.damage_summary(damage) if damage else ""
        if not played and not damage:
            # Every pass would play nothing again: with --loop, at once and for ever.
            where = f" from --start-offset {args.start_offset:g} s on" if args.start_offset else ""
            print(
                f"pyconnect: warning: nothing to play: {info.path} has no message{where}",
                file=err,
            )
            return late, damage, summary
        if not args.loop or damage:  # a damaged bag plays once: its damage is reported then
            return late, damage, summary


class Lateness:
    """How late messages were published against their schedule: a count, a sum and the worst,
    not one number per message (``--loop`` plays for hours)."""

    def __init__(self) -> None:
        self.count = 0
        self.total = 0.0
        self.worst = 0.0

    def add(self, seconds: float) -> None:
        self.count += 1
        self.total += seconds
        self.worst = seconds if self.count == 1 else max(self.worst, seconds)

    @property
    def mean(self) -> float:
        return self.total / self.count if self.count else 0.0


def _clock(ns: int) -> Any:
    from rosgraph_msgs.msg import Clock  # type: ignore[import-untyped]

    message = Clock()
    message.clock.sec, message.clock.nanosec = divmod(ns, 1_000_000_000)
    return message
