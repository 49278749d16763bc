"""Find the line at fault in a message by parsing parts of it: rosidl's parsers do not say which.

Each try parses the lines it is given, so the searches keep the lines parsed in all near the
message's own count (trying every prefix parsed them quadratically: minutes for a few hundred
lines of a bag's definition).
"""

from __future__ import annotations

from collections.abc import Callable

# Whether the message made of lines [first, end) of a text fails.
Fails = Callable[[int, int], bool]


def line_at_fault(fails: Fails, start: int, stop: int) -> int | None:
    """The number (1-based) of a line of [start, stop), a message that fails, at fault; None
    when even the empty message fails, so that no line is."""
    if fails(start, start):
        return None
    alone = _line_failing_alone(fails, start, stop)
    return alone if alone is not None else _line_failing_after(fails, start, stop)


def _line_failing_alone(fails: Fails, start: int, stop: int) -> int | None:
    """A line of [start, stop) (which fails) that fails on its own, the earliest one halving
    finds: rosidl reads each line of a message by itself, so a fault is usually one line's.
    The lines parsed add up to at most twice the part's. None when no half fails alone."""
    while stop - start > 1:
        middle = (start + stop) // 2
        if fails(start, middle):
            stop = middle
        elif fails(middle, stop):
            start = middle
        else:
            return None
    return stop


def _line_failing_after(fails: Fails, start: int, stop: int) -> int:
    """A line whose addition to the lines before it makes the message fail (a fault of two
    lines: a name declared twice), by bisecting the prefixes between ``start``, where the empty
    message passes, and ``stop``, where it fails: a logarithmic number of parses."""
    passes, failing = start, stop
    while failing - passes > 1:
        middle = (passes + failing) // 2
        if fails(start, middle):
            failing = middle
        else:
            passes = middle
    return failing
