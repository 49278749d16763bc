"""argparse ``type=`` functions for the commands' numeric options: each refusal says what it
expected (``argument -r/--rate: expected a number > 0 and <= 1e+09, got 'nan'``, exit status 2),
where argparse's own would say ``invalid float value`` or let ``nan`` and ``inf`` through."""

from __future__ import annotations

import argparse
import math

__all__ = [
    "nonnegative_int",
    "nonnegative_seconds",
    "positive_float",
    "positive_int",
    "split_bytes",
    "split_seconds",
]

MAX_SECONDS = (2**63 - 1) / 1e9
"""The longest time a ROS stamp or rcl timer can hold (int64 nanoseconds), about 292 years."""


def _whole(text: str) -> int | None:
    """``text`` as a whole number, or None when it is not one."""
    try:
        return int(text)
    except ValueError:
        return None


def _real(text: str) -> float:
    """``text`` as a float; NaN (which every range check refuses) when it is not one."""
    try:
        return float(text)
    except ValueError:
        return math.nan


def positive_int(text: str) -> int:
    """A count of 1 or more (``--window``)."""
    count = _whole(text)
    if count is None or count < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {text!r}")
    return count


def nonnegative_int(text: str) -> int:
    """A count of 0 or more (``--times``)."""
    count = _whole(text)
    if count is None or count < 0:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 0, got {text!r}")
    return count


MAX_RATE = 1e9
"""The largest rate or speed factor taken: times scaled by more overflow a ROS stamp's int64
nanoseconds within seconds (``bag play --rate 1e308 --clock`` failed on an OverflowError)."""


def positive_float(text: str) -> float:
    """A number above 0 up to ``MAX_RATE`` (``--rate``)."""
    number = _real(text)
    if not 0 < number <= MAX_RATE:  # NaN fails both comparisons
        raise argparse.ArgumentTypeError(f"expected a number > 0 and <= {MAX_RATE:g}, got {text!r}")
    return number


def nonnegative_seconds(text: str) -> float:
    """0 or more seconds, within a ROS duration's range (``--delay``, ``--start-offset``)."""
    seconds = _real(text)
    if not 0 <= seconds <= MAX_SECONDS:  # NaN fails both comparisons
        raise argparse.ArgumentTypeError(
            f"expected a number of seconds from 0 to {MAX_SECONDS:.3g}, got {text!r}"
        )
    return seconds


def split_bytes(text: str) -> int:
    """``bag record --max-bag-size``: bytes, 0 or more (0: no split by size)."""
    size = _whole(text)
    if size is None or size < 0:
        raise argparse.ArgumentTypeError(
            f"expected a whole number of bytes >= 0 (0: no split), got {text!r}"
        )
    return size


MIN_SPLIT_SECONDS = 1e-9
"""The shortest split duration: one nanosecond, the unit of log times and of the limit."""


def split_seconds(text: str) -> float:
    """``bag record --max-bag-duration``: seconds, 0 (no split by duration) or 1 ns or more."""
    seconds = _real(text)
    # Not finite: no file could ever end, and the limit in ns would not be a number.
    if not (math.isfinite(seconds) and seconds >= 0):
        raise argparse.ArgumentTypeError(
            f"expected a number of seconds >= 0 (0: no split), got {text!r}"
        )
    if seconds > MAX_SECONDS:  # 1e300 s overflowed the limit in ns: a traceback
        raise argparse.ArgumentTypeError(
            f"expected at most {MAX_SECONDS:.3g} seconds (0: no split), got {text!r}"
        )
    # The limit is whole nanoseconds: 1e-10 s rounded to 0, which means never split.
    if 0 < seconds < MIN_SPLIT_SECONDS:
        raise argparse.ArgumentTypeError(
            f"expected at least {MIN_SPLIT_SECONDS:g} seconds (0: no split), got {text!r}"
        )
    return seconds
