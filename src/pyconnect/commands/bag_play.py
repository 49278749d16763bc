"""``pyconnect bag play``: republish a bag's messages with their original timing.

Each message is published (as its stored CDR bytes) when ``(log time - first log time -
start offset) / rate`` seconds have passed since playing began. Each topic is offered with the
QoS its publishers had when recorded (``offered_qos_profiles`` in the bag: reliable unless they
were all best effort; transient local when they all were), else the default profile. A topic
recorded as several types gets a publisher of each, and each message goes out on the one of its
own type. ``--clock`` also publishes the bag's time on ``/clock`` (before each message and every
25 ms) for nodes with ``use_sim_time``. When it ends, also by Ctrl-C or SIGTERM (exit 0), it
prints how late messages were published against their schedule (mean and max), the timing
error. A topic (or one type of it) is left out with a warning, and the others play, when its
type is not installed (as ``ros2 bag play`` does), its messages are not serialised as CDR, or
ROS 2 refuses its name. A damaged bag plays all that can be read, then its damage is reported
and the exit status is 1 (``--ignore-damage``: 0; with ``--loop`` it then plays again and again,
the damage reported once). A ``--topics`` name not in the bag is an error (exit status 1); when
there is nothing to play (``--start-offset`` past the end), playing ends at once with a warning,
``--loop`` or not.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import argparse
import os
import signal
import threading
import time
from typing import TYPE_CHECKING, Any, TextIO

from pyconnect.commands.argument_types import nonnegative_seconds, positive_float
from pyconnect.commands.bag_damage import IGNORE_DAMAGE_HELP, damage_status
from pyconnect.errors import PyconnectError

if TYPE_CHECKING:
    from pyconnect.commands.common import Subcommands
    from pyconnect.record.bag_info import BagInfo, TopicInfo

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

    late = Lateness()
    damage: list[Any] = []
    summary = ""
    # SIGTERM (systemd, docker stop, timeout) stops playing as Ctrl-C does, as it ends
    # `bag record`: the summary and exit 0, not a process killed without its last line.
    main_thread = threading.current_thread() is threading.main_thread()
    previous_sigterm = signal.signal(signal.SIGTERM, _interrupt) if main_thread else None
    try:
        with graph_session("play") as session:
            if main_thread:  # the session's Ctrl-C handler, which waits for a spin to end
                signal.signal(signal.SIGTERM, signal.getsignal(signal.SIGINT))
            damage, summary = _play_all(args, session, late, out, err)
    except KeyboardInterrupt:  # Ctrl-C ends playing: a success, summed up as an end is
        pass
    except CommandFailed as failure:
        return report_failure(failure, err)
    finally:
        if previous_sigterm is not None:
            signal.signal(signal.SIGTERM, previous_sigterm)
    if late.count:
        print(
            f"Played {late.count} message(s); timing error: mean {late.mean * 1e3:.3f} ms, "
            f"max {late.worst * 1e3:.3f} ms",
            file=out,
        )
    return damage_status(damage, summary, args, err)


def _interrupt(_signum: int, _frame: Any) -> None:
    raise KeyboardInterrupt


def _play_all(
    args: argparse.Namespace, session: Any, late: Lateness, out: TextIO, err: TextIO
) -> tuple[list[Any], str]:
    """Play the bag, adding each message's timing error to ``late``; the damage the bag showed
    that is still to be reported, with its summary."""
    from rosgraph_msgs.msg import Clock  # type: ignore[import-untyped]

    from pyconnect.commands.graph import CommandFailed
    from pyconnect.record.bag_reader import open_bag

    info, stored = _stored_types(args.path)
    # One entry per topic: ``info`` lists a topic of two types twice, and ``stored`` has both.
    each = {t.name: t for t in reversed(info.topics)}  # reversed: a topic's first entry stays
    if args.topics is not None:
        names = sorted(each)
        unknown = [name for name in dict.fromkeys(args.topics) if name not in names]
        if unknown:  # as `bag echo --topic`: a typo must not play nothing and exit 0
            raise CommandFailed(
                f"{info.path}: no topic {', '.join(unknown)} in this bag "
                f"(topics: {', '.join(names) or 'none'})"
            )
    topics = [each[name] for name in sorted(each) if args.topics is None or name in args.topics]
    publishers = _Publishers(session)
    try:
        for topic in topics:
            publishers.add(topic, stored[topic.name], err)
        clock = session.node.create_publisher(Clock, "/clock", 10) if args.clock else None
        start_ns = (info.start_ns or 0) + round(args.start_offset * 1e9)
        if topics and not publishers.topics:
            raise CommandFailed(
                f"{info.path}: no topic to play: every one is left out (see the warnings)"
            )
        session.spin_for(args.delay)  # time for subscribers to discover the new publishers
        print(f"Playing {info.path} ({len(publishers.topics)} topic(s))", file=out, flush=True)
        reported = False  # the damage, said after a first pass when --loop goes on
        while True:
            selected = list(publishers.topics)
            with open_bag(args.path, topics=selected, raw=True, start_ns=start_ns) as bag:
                played = _play_pass(
                    bag, publishers, clock=clock, start_ns=start_ns, rate=args.rate, late=late
                )
                damage = [] if reported else bag.damage
                summary = bag.damage_summary(damage) if damage else ""
            if not played:
                if not damage and not reported:
                    # Every pass would play nothing again: with --loop, at once and for ever.
                    where = (
                        f" from --start-offset {args.start_offset:g} s on"
                        if args.start_offset
                        else ""
                    )
                    print(
                        f"pyconnect: warning: nothing to play: {info.path} has no message{where}",
                        file=err,
                    )
                return damage, summary
            # Without --ignore-damage the damage is an error, which ends the play after a pass.
            if not args.loop or (damage and not args.ignore_damage):
                return damage, summary
            if damage:  # every pass finds it again: said once, now, not after hours of loops
                damage_status(damage, summary, args, err)
                reported = True
    finally:
        publishers.close()


def _play_pass(
    bag: Any, publishers: _Publishers, *, clock: Any, start_ns: int, rate: float, late: Lateness
) -> int:
    """Publish the messages of ``bag`` each at its time; how many were published."""
    began = time.monotonic()
    last_clock = 0.0
    played = 0
    for message in bag:
        publisher = publishers.by_type.get((message.topic, message.msg_type))
        if publisher is None:  # a type of the topic left out, said when it was
            continue
        played += 1
        due = began + (message.log_time_ns - start_ns) / 1e9 / rate
        while True:
            now = time.monotonic()
            if clock is not None and now - last_clock >= CLOCK_PERIOD:
                elapsed_ns = round((now - began) * rate * 1e9)
                clock.publish(_clock(min(start_ns + elapsed_ns, message.log_time_ns)))
                last_clock = now
            if now >= due:
                break
            time.sleep(min(due - now, CLOCK_PERIOD))
        if clock is not None:
            clock.publish(_clock(message.log_time_ns))
        try:
            publisher.publish(bytes(message.value))
        finally:
            # Counted even when Ctrl-C or SIGTERM lands right after the publish (the handler
            # raises at the next instruction): a message that went out was missing from the
            # summary, and a stop after the first one printed no summary at all.
            late.add(time.monotonic() - due)
    return played


def _stored_types(path: str) -> tuple[BagInfo, dict[str, dict[str, set[str]]]]:
    """The bag's ``BagInfo``, and topic -> each of its types (``pkg/msg/Name``, in the order the
    bag declares them) -> how its messages are serialised (``BagInfo`` lists each topic and
    type, with counts but not the serialisation of every type of a topic)."""
    from pyconnect.record.bag_files import BagFiles, open_bag_files
    from pyconnect.record.bag_info import describe
    from pyconnect.record.bag_storage import StorageFile
    from pyconnect.record.topic_decoder import normalise_type_name

    bags: list[tuple[BagFiles, list[StorageFile]]] = []
    try:
        info = describe(open_bag_files(path, into=bags, caller="bag_info"))
        found: dict[str, dict[str, set[str]]] = {}
        for located, storages in bags:
            declared = [
                (c.topic, c.msg_type, c.serialization_format)
                for storage in storages
                for c in storage.connections()
            ]
            if located.metadata is not None:  # a topic it lists may be in no file
                declared += [
                    (t.name, t.msg_type, t.serialization_format) for t in located.metadata.topics
                ]
            for topic, msg_type, serialization_format in declared:
                formats = found.setdefault(topic, {}).setdefault(
                    normalise_type_name(msg_type), set()
                )
                formats.add((serialization_format or "cdr").lower())  # rosbag2 writes "" as cdr
        return info, found
    finally:
        for _, storages in bags:
            for storage in storages:
                storage.close()


def _leave_out(what: str, why: str, err: TextIO) -> None:
    print(f"pyconnect: warning: not playing {what}: {why}", file=err)


class _Publishers:
    """A play's publishers, one per topic and type, and the nodes that hold them.

    A participant takes one type per topic name (Fast DDS refuses a second), so a topic's
    second type is published from a node in a context of its own, its third from another, and
    so on: the subscribers of each type get the messages of their type, and only those.
    """

    def __init__(self, session: Any) -> None:
        self.by_type: dict[tuple[str, str], Any] = {}
        """(topic, ``pkg/msg/Name``) -> its publisher."""
        self.topics: dict[str, int] = {}
        """Topic -> how many of its types are published."""
        self._nodes: list[Any] = [session.node]
        self._contexts: list[Any] = []

    def add(self, topic: TopicInfo, types: dict[str, set[str]], err: TextIO) -> None:
        """Publishers for the ``types`` of ``topic`` (each with the serialisations it is stored
        in); each type left out is said on ``err``."""
        from rclpy.exceptions import InvalidTopicNameException

        from pyconnect.commands.graph import message_class

        qos = offered_qos(topic.offered_qos_profiles)
        for msg_type, formats in types.items():
            what = f"{topic.name} ({msg_type})" if len(types) > 1 else topic.name
            other = sorted(formats - {"cdr"})
            if other:  # its bytes would reach the subscribers as CDR that is not
                serialised = ", ".join(other)
                _leave_out(what, f"serialised as {serialised}, not cdr (only CDR plays)", err)
                continue
            try:
                # An action's or service's part (/fib/_action/feedback) is a type of its own.
                msg_class = message_class(msg_type)
            except PyconnectError as error:
                # As ros2 bag play: the other topics still play (tf2_msgs is not in the wheels).
                why = f"{error} (codecgen build --compile builds a type from its definition)"
                _leave_out(what, why, err)
                continue
            node = self._node(self.topics.get(topic.name, 0))
            try:
                publisher = node.create_publisher(msg_class, topic.name, qos)
            except (InvalidTopicNameException, ValueError) as error:  # ValueError: "{x}"
                # rclpy's text spans lines with a caret under the fault: its first line says it.
                reason = str(error).splitlines()[0].split(", at /")[0].rstrip(":")
                reason = reason.removeprefix("Invalid topic name: ")
                _leave_out(topic.name, f"invalid topic name: {reason}", err)
                return
            self.by_type[(topic.name, msg_type)] = publisher
            self.topics[topic.name] = self.topics.get(topic.name, 0) + 1

    def _node(self, index: int) -> Any:
        """The ``index``-th node (0: the session's), made with its context on first use."""
        import rclpy
        from rclpy.context import Context
        from rclpy.node import Node
        from rclpy.signals import SignalHandlerOptions

        from pyconnect.commands.live_options import HIDDEN_PREFIX

        while len(self._nodes) <= index:
            context = Context()
            rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
            self._contexts.append(context)
            name = f"{HIDDEN_PREFIX}pyconnect_play_{os.getpid()}_{len(self._nodes)}"
            self._nodes.append(Node(name, context=context, start_parameter_services=False))
        return self._nodes[index]

    def close(self) -> None:
        """Destroy the nodes made here (the session closes its own) and shut their contexts."""
        try:
            for node in self._nodes[1:]:
                node.destroy_node()
        finally:
            for context in self._contexts:
                context.try_shutdown()
            self._nodes[1:] = []
            self._contexts = []


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
