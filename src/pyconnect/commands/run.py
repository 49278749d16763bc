"""``pyconnect run script.py`` / ``pyconnect run -m module``: run set up for large messages.

Starts a new Python interpreter with the environment pyconnect.ros.large_messages describes
(the Fast DDS shared-memory profile and glibc's ``MALLOC_MMAP_THRESHOLD_`` /
``MALLOC_TRIM_THRESHOLD_``), so the settings apply from the first allocation. It replaces this
process (``exec``): signals and the exit status are the program's own.
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import TYPE_CHECKING, TextIO

from pyconnect.commands.common import Parser, UsageError

if TYPE_CHECKING:
    from pyconnect.commands.common import Subcommands

EXAMPLES = """examples:
  pyconnect run camera_node.py --width 1920
  pyconnect run -m my_robot.vision
"""


def register(commands: Subcommands) -> Parser:
    """Add ``run`` to the ``pyconnect`` subparsers."""
    run = commands.add_parser(
        "run",
        help="run a Python program with Fast DDS and malloc set up for large messages",
        description="Run a Python program with the large-message settings "
        "(PYCONNECT_LARGE_MESSAGES=0 runs it unchanged).",
        epilog=EXAMPLES,
    )
    # Everything after the module (or the script) is the program's, as for python: REMAINDER
    # on -m itself, else argparse would take `-m mod --help` for pyconnect's own options.
    run.add_argument(
        "-m",
        dest="module",
        nargs=argparse.REMAINDER,
        metavar="MODULE ARGS",
        help="run a module, like python -m; what follows goes to the module",
    )
    run.add_argument("program", nargs=argparse.REMAINDER, help="script.py and its arguments")
    run.set_defaults(run=_run)
    return run


def command_line(module: str | None, program: list[str]) -> list[str]:
    """The interpreter's argument list for ``pyconnect run``."""
    if module is not None:
        return [sys.executable, "-m", module, *program]
    if not program:
        raise UsageError("run: give a script (pyconnect run script.py) or -m module")
    return [sys.executable, *program]


def _run(args: argparse.Namespace, out: TextIO | None, err: TextIO | None) -> int:
    # out / err are None when the shell closed them (``2>&-``): python still runs the program.
    from pyconnect.ros.large_messages import SegmentSizeError, configure_environment

    module, program = None, list(args.program)
    if args.module is not None:
        if not args.module:
            raise UsageError("run: argument -m: expected a module name")
        # REMAINDER on an option stops at "--" and takes only the module of "-mmod": argparse
        # hands what follows to ``program``, still in order and with "--" kept, as python -m
        # passes it.
        module, program = args.module[0], [*args.module[1:], *program]
    argv = command_line(module, program)
    environ = dict(os.environ)
    try:
        reason = configure_environment(environ, default_on=True)
    except SegmentSizeError as error:
        raise UsageError(f"run: {error}") from None
    # print(file=None) would write to sys.stdout: the program's output, not a place for notes.
    if reason is not None and err is not None:
        print(f"pyconnect run: large-message settings not applied: {reason}", file=err)
    for stream in (out, err):
        if stream is not None:
            stream.flush()
    os.execve(sys.executable, argv, environ)
    return 0  # not reached
