"""argparse ``type=`` functions for the commands' numeric options: each refusal says what it
expected (``argument -r/--rate: expected a number > 0 and <= 1e+09, got 'nan'``, exit status 2),
where argparse's own would say ``invalid float value`` or let ``nan`` and ``inf`` through."""

from __future__ import annotations

import argparse
import math

__all__ = ["nonnegative_int", "nonnegative_seconds", "positive_float", "positive_int"]

MAX_SECONDS = (2**63 - 1) / 1e9
"""The longest time a ROS stamp or rcl timer can hold (int64 nanoseconds), about 292 years."""


def positive_int(text: str) -> int:
    """A count of 1 or more (``--window``)."""
    try:
        count = int(text)
    except ValueError:
        count = 0
    if count < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {text!r}")
    return count


def nonnegative_int(text: str) -> int:
    """A count of 0 or more (``--times``)."""
    try:
        count = int(text)
    except ValueError:
        count = -1
    if count < 0:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 0, got {text!r}")
    return count


MAX_RATE = 1e9
"""The largest rate or speed factor taken: times scaled by more overflow a ROS stamp's int64
nanoseconds within seconds (``bag play --rate 1e308 --clock`` failed on an OverflowError)."""


def positive_float(text: str) -> float:
    """A number above 0 up to ``MAX_RATE`` (``--rate``)."""
    try:
        number = float(text)
    except ValueError:
        number = math.nan
    if not 0 < number <= MAX_RATE:  # NaN fails both comparisons
        raise argparse.ArgumentTypeError(f"expected a number > 0 and <= {MAX_RATE:g}, got {text!r}")
    return number


def nonnegative_seconds(text: str) -> float:
    """0 or more seconds, within a ROS duration's range (``--delay``, ``--start-offset``)."""
    try:
        seconds = float(text)
    except ValueError:
        seconds = math.nan
    if not 0 <= seconds <= MAX_SECONDS:  # NaN fails both comparisons
        raise argparse.ArgumentTypeError(
            f"expected a number of seconds from 0 to {MAX_SECONDS:.3g}, got {text!r}"
        )
    return seconds
