"""``pyconnect bag info|echo|export``: read rosbag2 bags (MCAP or sqlite3) without ROS.

Exit status: 0 on success; 1 when some messages could not be decoded or the bag is damaged
(each summarised on stderr, every intact message still printed or exported; ``--ignore-damage``
makes damage alone exit 0); 2 on an error (one line on stderr).
"""

from __future__ import annotations

import argparse
import decimal
import signal
import threading
from collections.abc import Callable, Sequence
from datetime import datetime, timezone
from typing import TYPE_CHECKING, Any, TextIO

from pyconnect.commands.argument_types import nonnegative_int
from pyconnect.commands.bag_damage import IGNORE_DAMAGE_HELP, damage_status
from pyconnect.commands.common import Parser, UsageError
from pyconnect.commands.value_text import (
    ImageSummary,
    field_of,
    format_value,
    to_json,
    to_yaml,
)

if TYPE_CHECKING:
    from pyconnect.commands.common import Subcommands
    from pyconnect.record.bag_info import BagInfo

__all__ = ["PROGRAM", "format_value", "print_info", "register", "seconds_to_ns"]

PROGRAM = "pyconnect"
_PATH_HELP = "bag directory, .mcap or .db3 file"

EXAMPLES = """examples:
  pyconnect bag info run1
  pyconnect bag echo run1 --topic /chatter --limit 5
  pyconnect bag echo run1.mcap --topic /odom --field pose.pose.position --json
  pyconnect bag export run1 --topic /camera/image_raw --to images
  pyconnect bag export run1 --format parquet --to tables
  pyconnect bag record -a -o run1
  pyconnect bag play run1 --rate 2 --loop
"""


def register(commands: Subcommands) -> Subcommands:
    """Add ``bag`` and its actions to ``commands`` (the ``pyconnect`` subparsers).

    Returns the ``bag`` actions' subparsers so that other modules can add actions beside these
    (``bag record``, ``bag play``).
    """
    bag = commands.add_parser(
        "bag", help="read, export, record and play rosbag2 bags (MCAP or sqlite3)", epilog=EXAMPLES
    )
    actions = bag.add_subparsers(dest="action", required=True, parser_class=Parser)

    info = actions.add_parser(
        "info", help="files, size, duration, topics and services", epilog=EXAMPLES
    )
    info.add_argument("path", help=_PATH_HELP)
    info.add_argument("--ignore-damage", action="store_true", help=IGNORE_DAMAGE_HELP)
    info.set_defaults(run=_stops_on_sigterm(_info))

    echo = actions.add_parser(
        "echo", help="print messages (YAML like `ros2 topic echo`)", epilog=EXAMPLES
    )
    echo.add_argument("path", help=_PATH_HELP)
    echo.add_argument("--topic", action="append", help="only this topic (repeatable)")
    echo.add_argument("--limit", type=nonnegative_int, default=None, help="stop after N messages")
    echo.add_argument("--json", action="store_true", help="one JSON object per line")
    echo.add_argument(
        "--field", default=None, help="print only this field (dotted: pose.position.x)"
    )
    echo.add_argument("--start", type=_seconds, default=None, help="from this time (seconds)")
    echo.add_argument("--end", type=_seconds, default=None, help="up to this time (seconds)")
    echo.add_argument("--dict", action="store_true", help="lossless dicts, not natural values")
    echo.add_argument("--ignore-damage", action="store_true", help=IGNORE_DAMAGE_HELP)
    echo.set_defaults(run=_stops_on_sigterm(_echo))

    export = actions.add_parser("export", help="write topics' messages to files", epilog=EXAMPLES)
    export.add_argument("path", help=_PATH_HELP)
    export.add_argument(
        "--topic", action="append", help="a topic to export (repeatable; parquet: default all)"
    )
    export.add_argument(
        "--format",
        choices=["files", "parquet"],
        default="files",
        help="files: JSON/PNG/NPY per message; parquet: one table per topic",
    )
    export.add_argument(
        "--images",
        choices=["binary", "files"],
        default="binary",
        help="parquet: images as a binary data column (default) or as PNG files with a "
        "data_path column relative to the Parquet file",
    )
    export.add_argument("--to", required=True, help="output directory (created if needed)")
    export.add_argument("--force", action="store_true", help="overwrite an earlier export")
    export.add_argument("--dict", action="store_true", help="lossless dicts, not natural values")
    export.add_argument("--ignore-damage", action="store_true", help=IGNORE_DAMAGE_HELP)
    export.set_defaults(run=_stops_on_sigterm(_export))
    return actions


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


def _format_size(size: int) -> str:
    value = float(size)
    for unit in ("B", "KiB", "MiB", "GiB"):
        if value < 1024 or unit == "GiB":
            return f"{size} B" if unit == "B" else f"{value:.1f} {unit}"
        value /= 1024
    return f"{size} B"  # pragma: no cover - the loop always returns


def _seconds(text: str) -> decimal.Decimal:
    """An argparse ``type`` for ``--start``/``--end``: kept decimal, not float, because an
    absolute stamp has 19 significant digits and a float holds about 16 (``--start
    1778234358.028684`` would miss the message stamped at exactly that time)."""
    try:
        seconds = decimal.Decimal(text.strip())
    except decimal.InvalidOperation:
        raise argparse.ArgumentTypeError(f"expected seconds, got {text!r}") from None
    if not seconds.is_finite():
        raise argparse.ArgumentTypeError(f"expected a finite number of seconds, got {text!r}")
    return seconds


def seconds_to_ns(seconds: decimal.Decimal | float | None, bag_start_ns: int | None) -> int | None:
    """``--start``/``--end`` in ns: an absolute time, or an offset from the bag's start when
    it is smaller than the start (``--start 2.5`` is 2.5 s into the bag).

    A float is taken as the decimal it prints as (``repr``), so that a stamp copied into a
    float keeps its nanoseconds as far as the float's digits reach.
    """
    if seconds is None:
        return None
    exact = seconds if isinstance(seconds, decimal.Decimal) else decimal.Decimal(repr(seconds))
    # Enough digits for any stamp with sub-nanosecond decimals: the default 28 could round.
    with decimal.localcontext() as context:
        context.prec = 60
        ns = int(exact.scaleb(9).to_integral_value(rounding=decimal.ROUND_HALF_EVEN))
    if bag_start_ns is not None and ns < bag_start_ns:
        return bag_start_ns + ns
    return ns


# -- commands ---------------------------------------------------------------------------------
def _print_topics(out: TextIO, title: str, topics: Sequence[Any], unit: str) -> None:
    print(f"{title:<11}{len(topics)}", file=out)
    name_width = max((len(t.name) for t in topics), default=0)
    type_width = max((len(t.msg_type) for t in topics), default=0)
    count_width = max((len(str(t.message_count)) for t in topics), default=0)
    for topic in topics:
        print(
            f"  {topic.name:<{name_width}}  {topic.msg_type:<{type_width}}  "
            f"{topic.message_count:>{count_width}} {unit}  {topic.serialization_format}",
            file=out,
        )


def print_info(info: BagInfo, out: TextIO) -> None:
    """The ``bag info`` text: what ``ros2 bag info`` shows, topics and services apart."""
    files = len(info.files)
    print(f"path:      {info.path}", file=out)
    print(f"storage:   {info.storage} ({files} file{'s' if files != 1 else ''})", file=out)
    for path in info.files:
        size = path.stat().st_size if path.exists() else 0
        print(f"  {path.name}  {_format_size(size)}", file=out)
    print(f"size:      {_format_size(info.size_bytes)}", file=out)
    print(f"messages:  {info.message_count}", file=out)
    print(f"start:     {_format_time(info.start_ns)}", file=out)
    print(f"end:       {_format_time(info.end_ns)}", file=out)
    print(f"duration:  {_format_duration(info.duration_ns)}", file=out)
    services = info.services
    topics = [t for t in info.topics if t not in services]
    _print_topics(out, "topics:", topics, "msgs")
    _print_topics(out, "services:", services, "events")


def _info(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from pyconnect.record.bag_reader import bag_info

    info = bag_info(args.path)
    print_info(info, out)
    if not info.damage:
        return 0
    summary = f"{info.path}: damaged bag: {info.damage[0]}"
    return damage_status(info.damage, summary, args, err)


Run = Callable[[argparse.Namespace, TextIO, TextIO], int]


def _stops_on_sigterm(run: Run) -> Run:
    """``run`` with SIGTERM (``timeout``, ``docker stop``, systemd) ending it as Ctrl-C does:
    killed outright, it left the decompressed copy of a bag compressed per file behind (Python
    runs no cleanup for a signal it does not handle). ``bag play`` and ``bag record`` handle
    it themselves, with their summaries."""

    def stoppable(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
        if threading.current_thread() is not threading.main_thread():
            return run(args, out, err)  # only the main thread may set a handler
        previous = signal.signal(signal.SIGTERM, _interrupt)
        try:
            return run(args, out, err)
        finally:
            signal.signal(signal.SIGTERM, previous)

    return stoppable


def _interrupt(_signum: int, _frame: object) -> None:
    raise KeyboardInterrupt


def _report_problems(errors: Sequence[Any], err: TextIO) -> int:
    if not errors:
        return 0
    print(f"{PROGRAM}: {len(errors)} message(s) not decoded; first: {errors[0]}", file=err)
    return 1


def _echo(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from pyconnect.record.bag_reader import bag_info, open_bag

    start_ns = end_ns = None
    if args.start is not None or args.end is not None:
        first = bag_info(args.path).start_ns
        start_ns = seconds_to_ns(args.start, first)
        end_ns = seconds_to_ns(args.end, first)
        if end_ns is not None:
            end_ns += 1  # --end is inclusive, as ros2 bag takes it
    natural = not (args.dict or args.field)  # field names are the ROS ones
    printed = 0
    with open_bag(
        args.path, topics=args.topic, natural=natural, start_ns=start_ns, end_ns=end_ns
    ) as bag:
        for message in bag:
            if args.limit is not None and printed >= args.limit:
                break
            value = message.value
            if args.field:
                try:
                    value = field_of(value, args.field)
                except KeyError as error:
                    raise UsageError(
                        f"--field {args.field}: {message.topic}: {error.args[0]}"
                    ) from None
                value = _image_summary(message.msg_type, args.field, value, err)
            if args.json:
                record = {
                    "topic": message.topic,
                    "log_time_ns": message.log_time_ns,
                    "msg_type": message.msg_type,
                    "value": value.as_dict() if isinstance(value, ImageSummary) else value,
                }
                print(to_json(record), file=out)
            else:
                seconds, nanoseconds = divmod(message.log_time_ns, 1_000_000_000)
                print(f"# {message.topic} {seconds}.{nanoseconds:09d} {message.msg_type}", file=out)
                shown = repr(value) if isinstance(value, ImageSummary) else value
                print(to_yaml(shown), end="", file=out)
                print("---", file=out)
            printed += 1
        errors = list(bag.errors)
        damage = bag.damage
        summary = bag.damage_summary(damage) if damage else ""
        notes = list(bag.notes)
    for note in notes:
        # Topics no --topic named that cannot be decoded: said, though not an error.
        print(f"{PROGRAM}: {note}", file=err)
    status = _report_problems(errors, err)
    return max(status, damage_status(damage, summary, args, err))


_IMAGES = ("sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage")


def _image_summary(msg_type: str, path: str, value: Any, err: TextIO) -> Any:
    """An image field's one-line summary, as ``topic echo --field`` shows it; ``value`` (the
    field's dict) for any other field, or an image that does not decode (said on ``err``)."""
    from pyconnect.codecs import wire

    field_type = _field_type(msg_type, path)
    if field_type not in _IMAGES or not isinstance(value, dict):
        return value
    try:
        pixels = wire.decode(wire.from_dict(value, field_type), field_type)
    except Exception as error:  # a short frame, a CompressedImage that is no jpeg or png
        problem = " ".join(str(error).split()) or type(error).__name__
        print(f"{PROGRAM}: warning: cannot decode the image (shown as its fields): {problem}",
              file=err)  # fmt: skip
        return value
    return ImageSummary(pixels, str(value.get("encoding") or value.get("format") or ""))


def _field_type(msg_type: str, path: str) -> str | None:
    """The message type of field ``path`` of ``msg_type`` (None: a primitive, or a type
    without an installed definition): the fields' dicts do not say what they are."""
    from pyconnect.codecs import wire

    try:
        definitions = wire.wire_codec(msg_type).definitions
    except Exception:  # known to the bag only: its field shows as its dict
        return None
    current = msg_type
    for name in path.split("."):
        if name.isdigit():  # an item of the sequence just named: of the same type
            continue
        rows = definitions.get(current, ("", ()))[1]
        row = next((row for row in rows if row[0] == name), None)
        if row is None or row[1] != "message":
            return None
        current = row[2]
    return current


def _export(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from pyconnect.record.bag_export import export_topics
    from pyconnect.record.bag_reader import open_bag

    if args.format == "parquet":
        from pyconnect.commands.bag_tables import export_parquet_command

        return export_parquet_command(args, out, err)
    if args.images != "binary":
        raise UsageError("--images is for --format parquet")
    if not args.topic:
        raise UsageError("the following arguments are required: --topic")

    results = export_topics(args.path, args.topic, args.to, natural=not args.dict, force=args.force)
    status = 0
    damage: list[Any] = []
    read = 0
    for topic, result in results.items():
        written = ", ".join(f"{count} {kind}" for kind, count in sorted(result.files.items()))
        print(
            f"{topic}: {result.messages} message(s) to {result.directory}: {written or 'none'}",
            file=out,
        )
        status = max(status, _report_problems(result.errors, err))
        if result.damage and not damage:
            damage = result.damage
        read += result.messages + len(result.errors)  # every message read, written or not
    summary = ""
    if damage:
        # A topic's own summary counts only its messages and its promise: sum every topic's.
        with open_bag(args.path, topics=list(results)) as bag:
            summary = bag.damage_summary(damage, read=read)
    return max(status, damage_status(damage, summary, args, err))
