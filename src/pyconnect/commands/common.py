"""What every ``pyconnect`` subcommand shares (and ``codecgen`` with them): the argparse parser
class, ``UsageError``, and a closed stdout ending a command quietly."""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, NoReturn

__all__ = ["HelpFormatter", "Parser", "UsageError", "until_reader_leaves"]

if TYPE_CHECKING:
    # What ``add_subparsers()`` returns: command modules add their parsers to it.
    Subcommands = argparse._SubParsersAction["Parser"]


class UsageError(Exception):
    """A command line that cannot run; reported as one line with exit status 2."""


class HelpFormatter(argparse.HelpFormatter):
    """Wraps a one-paragraph description as argparse does, but keeps text laid out in lines
    (an ``examples:`` epilog) as written: argparse would run the examples into one paragraph."""

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        if "\n" in text.strip():
            return "".join(indent + line for line in text.splitlines(keepends=True))
        return super()._fill_text(text, width, indent)


class Parser(argparse.ArgumentParser):
    """An argparse parser that raises ``UsageError`` instead of exiting and keeps examples one
    per line."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> NoReturn:
        raise UsageError(message)


def until_reader_leaves(run: Callable[[], int]) -> int:
    """``run()``'s exit status, or 0 when the reader of stdout went away (``... | head``): a
    reader that has seen enough is no error, as for any shell tool."""
    try:
        status = run()
        # Output still buffered would meet the closed pipe at exit, outside this handler.
        sys.stdout.flush()
        return status
    except BrokenPipeError:
        # Python flushes stdout once more at exit and would report the same pipe there.
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
            os.close(devnull)
        except (OSError, ValueError):  # stdout is no file (captured): nothing left to flush
            pass
        return 0
