"""``pyconnect bag record``: record live topics into a rosbag2 MCAP bag, as ``ros2 bag record``.

``pyconnect bag record -a -o run1`` records every topic (new ones as they appear, checked each
second); ``pyconnect bag record /chatter /odom -o run1`` records those. Messages are stored as
received (raw CDR, no decoding) with their receipt time as log time, the definitions of the
installed types, and each topic's publishers' QoS as ``offered_qos_profiles`` (what ``bag play``
offers again). ``--max-bag-size`` (bytes) and ``--max-bag-duration`` (seconds) split the
recording into ``run1_0.mcap``, ``run1_1.mcap``, ...; ``metadata.yaml`` lists them all.
Ctrl-C stops the recording and leaves a complete bag (every file finished, metadata written).
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

if TYPE_CHECKING:
    from pyconnect.commands.common import Subcommands
    from pyconnect.commands.graph import GraphSession
    from pyconnect.record.mcap_recorder import McapRecorder

__all__ = ["register"]

EXAMPLES = """examples:
  pyconnect bag record -a -o run1
  pyconnect bag record /camera/image_raw /joint_states -o run2 --max-bag-duration 60
"""

_RELIABILITY = {"RELIABLE": 1, "BEST_EFFORT": 2}
_DURABILITY = {"TRANSIENT_LOCAL": 1, "VOLATILE": 2}
_HISTORY = {"KEEP_LAST": 1, "KEEP_ALL": 2}
_LIVELINESS = {"AUTOMATIC": 1, "MANUAL_BY_TOPIC": 3}
_INFINITE = {"sec": 2147483647, "nsec": 4294967295}


def _duration(value: Any) -> dict[str, int]:
    ns = int(value.nanoseconds)
    if ns <= 0 or ns >= _INFINITE["sec"] * 1_000_000_000:
        return dict(_INFINITE)  # rclpy's Infinite, as rosbag2 writes it
    sec, nsec = divmod(ns, 1_000_000_000)
    return {"sec": sec, "nsec": nsec}


def register(actions: Subcommands) -> None:
    """Add ``record`` to the ``bag`` actions."""
    record = actions.add_parser(
        "record",
        help="record live topics to a rosbag2 MCAP bag",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    record.add_argument("topics", nargs="*", help="topics to record")
    record.add_argument("-a", "--all", action="store_true", help="record every topic")
    record.add_argument("-o", "--output", required=True, help="the new bag directory")
    record.add_argument("-s", "--storage", default="mcap", choices=["mcap"], help="mcap")
    record.add_argument(
        "-b", "--max-bag-size", type=int, default=0, help="split files at this many bytes"
    )
    record.add_argument(
        "-d", "--max-bag-duration", type=float, default=0, help="split files every S seconds"
    )
    record.set_defaults(run=_record)


def _qos_yaml(endpoints: list[Any]) -> str:
    """The publishers' QoS as rosbag2 writes ``offered_qos_profiles`` (a YAML list)."""
    import yaml

    profiles = []
    for endpoint in endpoints:
        qos = endpoint.qos_profile
        profiles.append(
            {
                "history": _HISTORY.get(qos.history.name, 3),  # 3: unknown
                "depth": int(qos.depth),
                "reliability": _RELIABILITY.get(qos.reliability.name, 0),
                "durability": _DURABILITY.get(qos.durability.name, 0),
                "deadline": _duration(qos.deadline),
                "lifespan": _duration(qos.lifespan),
                "liveliness": _LIVELINESS.get(qos.liveliness.name, 0),
                "liveliness_lease_duration": _duration(qos.liveliness_lease_duration),
                "avoid_ros_namespace_conventions": False,
            }
        )
    return yaml.safe_dump(profiles, sort_keys=False) if profiles else ""


@dataclass
class _Split:
    """The bag directory, its files so far and the counts metadata.yaml needs."""

    directory: Path
    max_bytes: int
    max_ns: int
    files: list[dict[str, Any]] = field(default_factory=list)
    counts: dict[str, int] = field(default_factory=dict)
    types: dict[str, str] = field(default_factory=dict)
    qos: dict[str, str] = field(default_factory=dict)
    skipped: set[str] = field(default_factory=set)
    recorder: McapRecorder | None = None
    file_start_ns: int = 0
    file_bytes: int = 0
    file_first: int | None = None
    file_last: int = 0
    file_count: int = 0

    def open_next(self) -> McapRecorder:
        from pyconnect.record.mcap_recorder import McapRecorder

        self.finish_file()
        index = len(self.files)
        recorder = McapRecorder(self.directory / f"{self.directory.name}_{index}.mcap")
        for topic, msg_type in self.types.items():
            recorder.add_topic(topic, msg_type, offered_qos_profiles=self.qos[topic])
        self.recorder = recorder
        self.file_bytes = 0
        self.file_first = None
        self.file_count = 0
        return recorder

    def add_topic(self, topic: str, msg_type: str, qos: str) -> None:
        self.types[topic] = msg_type
        self.qos[topic] = qos
        self.counts.setdefault(topic, 0)
        if self.recorder is not None:
            self.recorder.add_topic(topic, msg_type, offered_qos_profiles=qos)

    def write(self, topic: str, data: bytes, now_ns: int) -> None:
        recorder = self.recorder if self.recorder is not None else self.open_next()
        full = (self.max_bytes and self.file_bytes >= self.max_bytes) or (
            self.max_ns and self.file_first is not None and now_ns - self.file_first >= self.max_ns
        )
        if full:
            recorder = self.open_next()
        recorder.write(topic, data, log_time_ns=now_ns)
        self.counts[topic] += 1
        self.file_bytes += len(data)
        self.file_count += 1
        if self.file_first is None:
            self.file_first = now_ns
        self.file_last = now_ns

    def finish_file(self) -> None:
        if self.recorder is None:
            return
        self.recorder.close()
        first = self.file_first or 0
        self.files.append(
            {
                "path": self.recorder.file_path.name,
                "starting_time": {"nanoseconds_since_epoch": first},
                "duration": {"nanoseconds": max(0, self.file_last - first)},
                "message_count": self.file_count,
            }
        )
        self.recorder = None

    def close(self) -> None:
        from pyconnect.record.bag_metadata import (
            METADATA_FILE,
            BagMetadata,
            TopicMetadata,
            write_metadata,
        )

        if self.recorder is None and not self.files:
            self.open_next()  # an empty recording is still a valid bag
        self.finish_file()
        starts = [
            f["starting_time"]["nanoseconds_since_epoch"] for f in self.files if f["message_count"]
        ]
        ends = [
            f["starting_time"]["nanoseconds_since_epoch"] + f["duration"]["nanoseconds"]
            for f in self.files
            if f["message_count"]
        ]
        start = min(starts, default=0)
        metadata = BagMetadata(
            storage_identifier="mcap",
            relative_file_paths=tuple(f["path"] for f in self.files),
            topics=tuple(
                TopicMetadata(
                    name=topic,
                    msg_type=msg_type,
                    offered_qos_profiles=self.qos[topic],
                    message_count=self.counts[topic],
                )
                for topic, msg_type in self.types.items()
            ),
            starting_time_ns=start,
            duration_ns=max(ends, default=start) - start,
            message_count=sum(self.counts.values()),
            files=tuple(self.files),
        )
        write_metadata(self.directory / METADATA_FILE, metadata)


def _subscribe_new(
    session: GraphSession, split: _Split, wanted: set[str] | None, out: TextIO
) -> None:
    from pyconnect.commands.graph import choose_qos
    from pyconnect.ros.interfaces import interface_class

    for topic, types in session.node.get_topic_names_and_types():
        if topic in split.types or topic in split.skipped or not types:
            continue
        if wanted is not None and topic not in wanted:
            continue
        hidden = any(part.startswith("_") for part in topic.split("/"))
        if wanted is None and (hidden or topic in ("/rosout", "/parameter_events")):
            continue  # as `ros2 bag record -a` leaves them out unless asked
        try:
            msg_class = interface_class(types[0], kind="msg")
        except Exception as error:
            print(f"skipping {topic}: {error}", file=out, flush=True)
            split.skipped.add(topic)
            continue
        publishers = session.node.get_publishers_info_by_topic(topic)
        split.add_topic(topic, types[0], _qos_yaml(publishers))

        def on_message(data: bytes, topic: str = topic) -> None:
            split.write(topic, data, time.time_ns())
            if split.counts[topic] == 1:
                print(f"Recording '{topic}': first message received", file=out, flush=True)

        qos = choose_qos(session, topic, None)
        session.node.create_subscription(msg_class, topic, on_message, qos, raw=True)
        print(f"Subscribed to topic '{topic}'", file=out, flush=True)


def _record(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from pyconnect.commands.graph import CommandFailed, graph_session, report_failure

    if args.all == bool(args.topics):
        return report_failure(CommandFailed("give either -a or the topics to record"), err)
    directory = Path(args.output)
    if directory.exists():
        return report_failure(CommandFailed(f"{directory}: already exists"), err)
    directory.mkdir(parents=True)
    split = _Split(directory, args.max_bag_size, round(args.max_bag_duration * 1e9))
    wanted = None if args.all else set(args.topics)
    try:
        with graph_session("record") as session:
            print(f"Recording to '{directory}'", file=out, flush=True)
            while True:
                _subscribe_new(session, split, wanted, out)
                session.spin_for(1.0)
    except KeyboardInterrupt:  # Ctrl-C is how a recording ends: a success
        return 0
    finally:
        split.close()
        print(f"Recorded {sum(split.counts.values())} message(s) to '{directory}'", file=out)
