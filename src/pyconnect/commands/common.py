"""What every ``pyconnect`` subcommand shares: the argparse parser class and ``UsageError``."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING, NoReturn

__all__ = ["Parser", "UsageError"]

if TYPE_CHECKING:
    # What ``add_subparsers()`` returns: command modules add their parsers to it.
    Subcommands = argparse._SubParsersAction["Parser"]


class UsageError(Exception):
    """A command line that cannot run; reported as one line with exit status 2."""


class Parser(argparse.ArgumentParser):
    """An argparse parser that raises ``UsageError`` instead of exiting."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(message)
