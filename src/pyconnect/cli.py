"""The ``pyconnect`` command: ``pyconnect bag info|echo|export`` on bag files, no ROS needed.

``main(argv)`` returns the exit status: 0 on success, 1 when some messages could not be decoded
(each summarised on stderr, the rest still printed or exported), 2 on an error (one line on
stderr, no traceback), 130 on Ctrl-C.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence
from datetime import datetime, timezone
from typing import Any, NoReturn, TextIO

import numpy as np

from pyconnect.errors import PyconnectError

__all__ = ["format_value", "main", "main_entry"]

PROGRAM = "pyconnect"


class _UsageError(Exception):
    """A command line argparse rejected; reported like any other error."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        raise _UsageError(message)


def _build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog=PROGRAM, description="pyconnect tools (no ROS graph needed)")
    commands = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    bag = commands.add_parser("bag", help="read rosbag2 bags (MCAP or sqlite3)")
    actions = bag.add_subparsers(dest="action", required=True, parser_class=_Parser)

    info = actions.add_parser("info", help="topics, types, counts and duration")
    info.add_argument("path", help="bag directory, .mcap or .db3 file")

    echo = actions.add_parser("echo", help="print decoded messages")
    echo.add_argument("path", help="bag directory, .mcap or .db3 file")
    echo.add_argument("--topic", action="append", help="only this topic (repeatable)")
    echo.add_argument("--limit", type=int, default=None, help="stop after N messages")
    echo.add_argument("--dict", action="store_true", help="lossless dicts, not natural values")

    export = actions.add_parser("export", help="write one topic's messages to files")
    export.add_argument("path", help="bag directory, .mcap or .db3 file")
    export.add_argument("--topic", required=True, help="the topic to export")
    export.add_argument("--to", required=True, help="output directory (created if needed)")
    export.add_argument("--dict", action="store_true", help="lossless dicts, not natural values")
    return parser


# -- formatting -------------------------------------------------------------------------------
def _format_time(ns: int | None) -> str:
    if ns is None:
        return "-"
    seconds, nanoseconds = divmod(ns, 1_000_000_000)
    utc = datetime.fromtimestamp(seconds, tz=timezone.utc).strftime("%Y-%m-%d %H:%M:%S")
    return f"{utc}.{nanoseconds:09d} UTC ({seconds}.{nanoseconds:09d})"


def _format_duration(ns: int) -> str:
    seconds, nanoseconds = divmod(ns, 1_000_000_000)
    return f"{seconds}.{nanoseconds:09d} s"


class _Summary:
    """Stands in for a big value in echo output; its repr is the summary."""

    def __init__(self, text: str) -> None:
        self.text = text

    def __repr__(self) -> str:
        return self.text


_MAX_ITEMS = 16


def _summarise(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        if value.size <= _MAX_ITEMS and value.dtype.names is None:
            return _Summary(f"array({value.tolist()!r}, dtype={value.dtype})")
        return _Summary(f"ndarray(shape={value.shape}, dtype={value.dtype})")
    if isinstance(value, bytes | bytearray | memoryview):
        data = bytes(value)
        return data if len(data) <= _MAX_ITEMS else _Summary(f"<{len(data)} bytes>")
    if isinstance(value, dict):
        return {key: _summarise(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        items = [_summarise(item) for item in value[:_MAX_ITEMS]]
        if len(value) > _MAX_ITEMS:
            items.append(_Summary(f"... {len(value) - _MAX_ITEMS} more"))
        return tuple(items) if isinstance(value, tuple) else items
    if isinstance(value, np.generic):
        return value.item()
    return value


def format_value(value: Any) -> str:
    """One line for a decoded value, with arrays and long sequences summarised."""
    return repr(_summarise(value))


# -- commands ---------------------------------------------------------------------------------
def _info(args: argparse.Namespace, out: TextIO) -> int:
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
        raise _UsageError(f"--limit: expected a count >= 0, got {args.limit}")
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


def main(argv: list[str] | None = None) -> int:
    """Run ``pyconnect`` with ``argv`` (``sys.argv[1:]`` when None); return the exit status."""
    out, err = sys.stdout, sys.stderr
    package_logger = logging.getLogger("pyconnect")
    if not package_logger.handlers:
        # The CLI prints its own summaries; without this, logging's last-resort handler would
        # print the reader's warning a second time.
        package_logger.addHandler(logging.NullHandler())
    try:
        args = _build_parser().parse_args(argv)
        if args.action == "info":
            return _info(args, out)
        if args.action == "echo":
            return _echo(args, out, err)
        return _export(args, out, err)
    except SystemExit as exit_request:  # --help
        code = exit_request.code
        return code if isinstance(code, int) else 0
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:  # `pyconnect bag echo ... | head`
        return 0
    except (_UsageError, PyconnectError, OSError, ValueError) as error:
        message = " ".join(str(error).split()) or type(error).__name__
        print(f"{PROGRAM}: error: {message}", file=err)
        return 2


def main_entry() -> None:
    """Console-script entry point."""
    sys.exit(main())


if __name__ == "__main__":
    main_entry()
