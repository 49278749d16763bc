"""How every ``bag`` subcommand ends on a damaged bag: the damage on stderr, then exit 1.

``--ignore-damage`` (``IGNORE_DAMAGE_HELP``) makes damage alone exit 0; it is still reported.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any, TextIO

__all__ = ["IGNORE_DAMAGE_HELP", "damage_status"]

IGNORE_DAMAGE_HELP = "exit 0 on a damaged bag (the damage is still reported on stderr)"


def damage_status(
    damage: Sequence[Any], summary: str, args: argparse.Namespace, err: TextIO
) -> int:
    """Print ``summary`` and every further problem of ``damage``; the exit status they give."""
    if not damage:
        return 0
    print(f"pyconnect: {summary}", file=err)
    for problem in damage[1:]:
        print(f"pyconnect:   also: {problem}", file=err)
    return 0 if getattr(args, "ignore_damage", False) else 1
