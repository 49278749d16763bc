"""``pyconnect bag info|echo|export``: read rosbag2 bags (MCAP or sqlite3) without ROS.

Exit status: 0 on success, 1 when some messages could not be decoded (each summarised on
stderr, the rest still printed or exported), 2 on an error (one line on stderr).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from datetime import datetime, timezone
from typing import TYPE_CHECKING, Any, TextIO

from pyconnect.commands.common import Parser, UsageError
from pyconnect.commands.value_text import format_value

if TYPE_CHECKING:
    from pyconnect.commands.common import Subcommands

__all__ = ["PROGRAM", "register"]

PROGRAM = "pyconnect"


def register(commands: Subcommands) -> Subcommands:
    """Add ``bag`` and its actions to ``commands`` (the ``pyconnect`` subparsers).

    Returns the ``bag`` parser's subparsers holder so that other modules can add actions
    (``bag record``, ``bag play``) beside these.
    """
    bag = commands.add_parser("bag", help="read rosbag2 bags (MCAP or sqlite3)")
    actions = bag.add_subparsers(dest="action", required=True, parser_class=Parser)

    info = actions.add_parser("info", help="topics, types, counts and duration")
    info.add_argument("path", help="bag directory, .mcap or .db3 file")
    info.set_defaults(run=_info)

    echo = actions.add_parser("echo", help="print decoded messages")
    echo.add_argument("path", help="bag directory, .mcap or .db3 file")
    echo.add_argument("--topic", action="append", help="only this topic (repeatable)")
    echo.add_argument("--limit", type=int, default=None, help="stop after N messages")
    echo.add_argument("--dict", action="store_true", help="lossless dicts, not natural values")
    echo.set_defaults(run=_echo)

    export = actions.add_parser("export", help="write one topic's messages to files")
    export.add_argument("path", help="bag directory, .mcap or .db3 file")
    export.add_argument("--topic", required=True, help="the topic to export")
    export.add_argument("--to", required=True, help="output directory (created if needed)")
    export.add_argument("--dict", action="store_true", help="lossless dicts, not natural values")
    export.set_defaults(run=_export)
    return actions


def _format_time(ns: int | None) -> str:
    if ns is None:
        return "-"
    seconds, nanoseconds = divmod(ns, 1_000_000_000)
    utc = datetime.fromtimestamp(seconds, tz=timezone.utc).strftime("%Y-%m-%d %H:%M:%S")
    return f"{utc}.{nanoseconds:09d} UTC ({seconds}.{nanoseconds:09d})"


def _format_duration(ns: int) -> str:
    seconds, nanoseconds = divmod(ns, 1_000_000_000)
    return f"{seconds}.{nanoseconds:09d} s"


def _info(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from pyconnect.record.bag_reader import bag_info

    info = bag_info(args.path)
    files = len(info.files)
    print(f"path:      {info.path}", file=out)
    print(f"storage:   {info.storage} ({files} file{'s' if files != 1 else ''})", file=out)
    print(f"messages:  {info.message_count}", file=out)
    print(f"start:     {_format_time(info.start_ns)}", file=out)
    print(f"end:       {_format_time(info.end_ns)}", file=out)
    print(f"duration:  {_format_duration(info.duration_ns)}", file=out)
    print(f"topics:    {len(info.topics)}", file=out)
    name_width = max((len(t.name) for t in info.topics), default=0)
    type_width = max((len(t.msg_type) for t in info.topics), default=0)
    count_width = max((len(str(t.message_count)) for t in info.topics), default=0)
    for topic in info.topics:
        print(
            f"  {topic.name:<{name_width}}  {topic.msg_type:<{type_width}}  "
            f"{topic.message_count:>{count_width}} msgs  {topic.serialization_format}",
            file=out,
        )
    return 0


def _report_problems(errors: Sequence[Any], err: TextIO) -> int:
    if not errors:
        return 0
    print(f"{PROGRAM}: {len(errors)} message(s) not decoded; first: {errors[0]}", file=err)
    return 1


def _echo(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from pyconnect.record.bag_reader import open_bag

    if args.limit is not None and args.limit < 0:
        raise UsageError(f"--limit: expected a count >= 0, got {args.limit}")
    printed = 0
    with open_bag(args.path, topics=args.topic, natural=not args.dict) as bag:
        for message in bag:
            if args.limit is not None and printed >= args.limit:
                break
            seconds, nanoseconds = divmod(message.log_time_ns, 1_000_000_000)
            print(
                f"{message.topic} {seconds}.{nanoseconds:09d} {format_value(message.value)}",
                file=out,
            )
            printed += 1
        errors = list(bag.errors)
    return _report_problems(errors, err)


def _export(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from pyconnect.record.bag_export import export_topic

    result = export_topic(args.path, args.topic, args.to, natural=not args.dict)
    written = ", ".join(f"{count} {kind}" for kind, count in sorted(result.files.items()))
    print(
        f"{args.topic}: {result.messages} message(s) to {result.directory}: {written or 'none'}",
        file=out,
    )
    return _report_problems(result.errors, err)
