"""``pyconnect bag record``: record live topics into a rosbag2 MCAP bag, as ``ros2 bag record``.

``pyconnect bag record -a -o run1`` records every topic (new ones as they appear, checked each
second); ``pyconnect bag record /chatter /odom -o run1`` records those. Messages are stored as
received (raw CDR, no decoding) with their receipt time as log time, the definitions of the
installed types, each topic's publishers' QoS as ``offered_qos_profiles`` (what ``bag play``
offers again) and their RIHS01 type hash as ``type_description_hash`` (what ``open_bag`` compares
with the installed type; "" when they give none or disagree, as rosbag2 stores it).
``--max-bag-size`` (bytes of the file, as ``ros2 bag record -b``; a file grows a compressed chunk
at a time) and ``--max-bag-duration`` (seconds) split the recording into ``run1_0.mcap``,
``run1_1.mcap``, ...; ``metadata.yaml`` lists them all, each from the moment it is created
(``pyconnect.record.split_recorder``).

No message is lost to the recorder being busy: a topic's file and definition are ready before
its subscription exists, and callbacks only queue the messages for a writer thread, which writes
them and splits the files (``pyconnect.record.queued_recorder``). Ctrl-C stops the recording
and leaves a complete bag (every received message written, every file finished, metadata
written): it is deferred while a topic is added, never reaches the writer thread, and a second
Ctrl-C waits for the bag to be finished. SIGTERM does the same as Ctrl-C. A disk that fills up
ends the recording with one error naming the bag and counting the received messages it does not
hold; its metadata.yaml says what its files hold. Messages DDS loses before they reach the
recorder (a 30 Hz 1080p camera outrunning the reader) are no failure of the bag but are never
silent: the first loss of a topic is logged with the count so far, and the last line counts
them per topic.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import argparse
import signal
import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

from pyconnect.commands.argument_types import split_bytes, split_seconds
from pyconnect.commands.live_options import expand_name

if TYPE_CHECKING:
    from collections.abc import Callable

    from pyconnect.commands.common import Subcommands
    from pyconnect.commands.graph import GraphSession
    from pyconnect.record.queued_recorder import QueuedRecorder
    from pyconnect.ros.recording_subscription import RecordingSubscription

__all__ = ["register"]

EXAMPLES = """examples:
  pyconnect bag record -a -o run1
  pyconnect bag record /camera/image_raw /joint_states -o run2 --max-bag-duration 60
"""


def register(actions: Subcommands) -> None:
    """Add ``record`` to the ``bag`` actions."""
    record = actions.add_parser(
        "record",
        help="record live topics to a rosbag2 MCAP bag",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    # ``chatter`` is ``/chatter``, as rosbag2's recorder expands it.
    record.add_argument("topics", nargs="*", type=expand_name, help="topics to record")
    record.add_argument("-a", "--all", action="store_true", help="record every topic")
    record.add_argument("-o", "--output", required=True, help="the new bag directory")
    record.add_argument("-s", "--storage", default="mcap", choices=["mcap"], help="mcap")
    record.add_argument(
        "-b",
        "--max-bag-size",
        type=split_bytes,
        default=0,
        help="split files at this many bytes on disk (checked as each compressed chunk of at "
        "most 1 MiB is written, as rosbag2 does)",
    )
    record.add_argument(
        "-d",
        "--max-bag-duration",
        type=split_seconds,
        default=0,
        help="split files every S seconds",
    )
    record.set_defaults(run=_record)


def _queue_into(writer: QueuedRecorder, topic: str, out: TextIO) -> Callable[[bytes], None]:
    """The subscription callback of ``topic``: stamp the message and queue it, nothing more."""
    first = True

    def on_message(data: bytes) -> None:
        nonlocal first
        writer.write(topic, data, log_time_ns=time.time_ns())
        if first:
            first = False
            print(f"Recording '{topic}': first message received", file=out, flush=True)

    return on_message


def _subscribe_new(
    session: GraphSession,
    writer: QueuedRecorder,
    wanted: set[str] | None,
    skipped: set[str],
    out: TextIO,
    *,
    readers: dict[str, RecordingSubscription],
) -> None:
    """Subscribe to the topics not recorded yet; ``readers`` gets each new subscription."""
    from pyconnect.ros.recording_qos import offered_qos_yaml, offered_type_hash
    from pyconnect.ros.recording_subscription import RecordingSubscription
    from pyconnect.typesys.classes import import_class
    from pyconnect.typesys.names import full_type_name

    split = writer.recorder
    for topic, types in session.node.get_topic_names_and_types():
        if topic in split.counts or topic in skipped or not types:
            continue
        if wanted is not None and topic not in wanted:
            continue
        hidden = any(part.startswith("_") for part in topic.split("/"))
        if wanted is None and (hidden or topic in ("/rosout", "/parameter_events")):
            continue  # as `ros2 bag record -a` leaves them out unless asked
        publishers = session.node.get_publishers_info_by_topic(topic)
        try:
            # Also the parts of services and actions (`pkg/action/Fibonacci_FeedbackMessage` is
            # the class Fibonacci.Impl.FeedbackMessage), which a module attribute is not.
            msg_class = import_class(full_type_name(types[0]))
            # Opens the bag's first file and reads the definition now, before the subscription
            # exists: done in the first callback, it cost ~0.1 s of messages.
            split.add_topic(
                topic,
                types[0],
                offered_qos_profiles=offered_qos_yaml(publishers),
                type_hash=offered_type_hash(publishers, types[0]),
            )
        except Exception as error:
            print(f"skipping {topic}: {error}", file=out, flush=True)
            skipped.add(topic)
            continue

        on_message = _queue_into(writer, topic, out)
        # Kept for its count of the messages DDS lost on the way, which the last line tells.
        readers[topic] = RecordingSubscription(
            session.node, msg_class=msg_class, topic=topic, write=on_message
        )
        print(f"Subscribed to topic '{topic}'", file=out, flush=True)


def _record(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from pyconnect.commands.graph import CommandFailed, graph_session, report_failure
    from pyconnect.record.queued_recorder import QueuedRecorder
    from pyconnect.record.split_recorder import SplitRecorder

    if args.all == bool(args.topics):
        return report_failure(CommandFailed("give either -a or the topics to record"), err)
    directory = Path(args.output)
    if directory.exists():
        return report_failure(CommandFailed(f"{directory}: already exists"), err)
    split = SplitRecorder(
        directory, max_bytes=args.max_bag_size, max_ns=round(args.max_bag_duration * 1e9)
    )
    writer = QueuedRecorder(split)
    wanted = None if args.all else set(args.topics)
    skipped: set[str] = set()
    readers: dict[str, RecordingSubscription] = {}
    # SIGTERM (systemd, docker stop, timeout) ends a recording as Ctrl-C does, as it does
    # `ros2 bag record`: a complete bag and exit 0, not a process killed with its data unwritten.
    main_thread = threading.current_thread() is threading.main_thread()
    previous_sigterm = signal.signal(signal.SIGTERM, _interrupt) if main_thread else None
    try:
        with graph_session("record") as session:
            if main_thread:  # the session's Ctrl-C handler, which defers it while bags are written
                signal.signal(signal.SIGTERM, signal.getsignal(signal.SIGINT))
            try:
                print(f"Recording to '{directory}'", file=out, flush=True)
                while True:
                    # Ctrl-C lands between callbacks and between these steps, never inside one
                    # (a split, a topic being added): the session defers it until they end.
                    with session.interrupts_deferred():
                        _subscribe_new(session, writer, wanted, skipped, out, readers=readers)
                    session.spin_for(1.0)
            except KeyboardInterrupt:  # Ctrl-C is how a recording ends: a success
                pass
            finally:
                # Nothing spins any more, so no callback queues; a second Ctrl-C waits until
                # the queued messages, the last file and metadata.yaml are written.
                with session.interrupts_deferred():
                    writer.close()
        return 0
    except KeyboardInterrupt:  # before the session could defer it, or a second Ctrl-C
        return 0
    finally:
        try:
            # Idempotent, and raises a failure of the bag once (a full disk: the BagError that
            # counts what was lost, not the OSError of finishing the file after it); finishes
            # the bag when the session never started.
            writer.close()
        finally:  # the counts are what the bag holds, even when it could not be finished
            print(_summary(sum(split.counts.values()), directory, readers), file=out)
            if previous_sigterm is not None:
                signal.signal(signal.SIGTERM, previous_sigterm)


def _summary(recorded: int, directory: Path, readers: dict[str, RecordingSubscription]) -> str:
    """The last line: what the bag holds and, when DDS lost any, what it lost per topic."""
    line = f"Recorded {recorded} message(s) to '{directory}'"
    lost = {topic: reader.lost_count for topic, reader in readers.items() if reader.lost_count}
    if not lost:
        return line
    from pyconnect.ros.recording_subscription import lost_text

    return f"{line}; DDS lost {lost_text(lost)} before they reached the recorder"


def _interrupt(_signum: int, _frame: Any) -> None:
    raise KeyboardInterrupt
