"""The ``pyconnect`` command: tools on bags (and, beside them, on a live graph) for users of the
PyPI ROS wheels, who have no ``ros2`` command.

Each command group lives in its own module under ``pyconnect.commands`` and is registered here
with one line. ``main(argv)`` returns the exit status: 0 on success, 1 when the command did its
work but has problems to report (each summarised on stderr) or met a value it could not handle,
2 on a bad command line or an error (one line on stderr, no traceback), 130 on Ctrl-C.

Text that the terminal's encoding cannot show (``PYTHONIOENCODING=ascii``, a latin-1 locale) is
written with backslash escapes (``snow \\u2603``): a value is never a reason to stop.
"""

from __future__ import annotations

import argparse
import io
import logging
import sys
from typing import TextIO

from pyconnect import __version__
from pyconnect.commands import action as action_commands
from pyconnect.commands import bag as bag_commands
from pyconnect.commands import bag_play, bag_record
from pyconnect.commands import interface as interface_commands
from pyconnect.commands import node as node_commands
from pyconnect.commands import run as run_commands
from pyconnect.commands import service as service_commands
from pyconnect.commands import topic as topic_commands
from pyconnect.commands.common import Parser, UsageError, until_reader_leaves
from pyconnect.commands.live_options import ros_missing
from pyconnect.commands.value_text import format_value
from pyconnect.errors import PyconnectError

__all__ = ["build_parser", "format_value", "main", "main_entry"]

PROGRAM = "pyconnect"


def build_parser() -> argparse.ArgumentParser:
    """The ``pyconnect`` parser with every command group registered."""
    parser = Parser(
        prog=PROGRAM,
        description=(
            "pyconnect tools: what the ros2 command does, for a pip-only install "
            "(bags and interfaces need no running ROS graph)"
        ),
    )
    parser.add_argument("--version", action="version", version=f"{PROGRAM} {__version__}")
    commands = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    bag_actions = bag_commands.register(commands)
    bag_record.register(bag_actions)
    bag_play.register(bag_actions)
    interface_commands.register(commands)
    topic_commands.register(commands)
    service_commands.register(commands)
    action_commands.register(commands)
    node_commands.register(commands)
    run_commands.register(commands)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run ``pyconnect`` with ``argv`` (``sys.argv[1:]`` when None); return the exit status."""
    for stream in (sys.stdout, sys.stderr):
        # Python opens them strict: the first string the encoding lacks ended an echo.
        if isinstance(stream, io.TextIOWrapper):
            stream.reconfigure(errors="backslashreplace")
    out, err = sys.stdout, sys.stderr
    package_logger = logging.getLogger("pyconnect")
    if not package_logger.handlers:
        # The CLI prints its own summaries; without this, logging's last-resort handler would
        # print the reader's warning a second time.
        package_logger.addHandler(logging.NullHandler())
    try:
        args = build_parser().parse_args(argv)
        status: int = until_reader_leaves(lambda: args.run(args, out, err))
        return status
    except SystemExit as exit_request:  # --help, --version
        code = exit_request.code
        return code if isinstance(code, int) else 0
    except KeyboardInterrupt:
        return 130
    except (UsageError, PyconnectError, OSError) as error:
        return _report_error(error, err)
    except ValueError as error:
        # Met at run time (a UnicodeError among them): not a bad command line, which argparse
        # and the argument types report as UsageError.
        return _report_error(error, err, status=1)
    except ModuleNotFoundError as error:
        # A live command in an install without the `ros` extra: rclpy is imported only when
        # one is read or run, so the bag and interface commands work without it.
        missing = ros_missing(error)
        if missing is None:
            raise
        return _report_error(missing, err)


def _report_error(error: Exception, err: TextIO, *, status: int = 2) -> int:
    """Print ``error`` as one line on ``err``; return ``status`` (2: the status of an error)."""
    message = " ".join(str(error).split()) or type(error).__name__
    print(f"{PROGRAM}: error: {message}", file=err)
    return status


def main_entry() -> None:
    """Console-script entry point."""
    sys.exit(main())


if __name__ == "__main__":
    main_entry()
