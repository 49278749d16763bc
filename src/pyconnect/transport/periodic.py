"""``run_every``: a peer's timers and periodic publishers, on a fixed schedule as rcl's timers.

The schedule is a monotonic deadline that moves on by exactly one period per call
(``rcl_timer_call``: "don't use now as the base"), so a callback's own run time does not
stretch the period. A callback that overruns makes the next call due at once; deadlines missed
meanwhile are skipped, not caught up on (rcl moves the next call time forward by as many
periods as needed): one late call, never a burst of them.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable

monotonic = time.monotonic


def next_deadline(deadline: float, period: float, now: float) -> float:
    """The deadline after ``deadline``, past the ones ``now`` has already missed."""
    deadline += period
    if deadline < now:
        deadline += math.ceil((now - deadline) / period) * period
    return deadline


def run_every(period: float, stop: threading.Event, tick: Callable[[], None]) -> None:
    """Call ``tick()`` every ``period`` seconds until ``stop`` is set (the first after one period).

    ``tick`` handles its own errors: one that escapes ends the schedule.
    """
    deadline = monotonic() + period
    while True:
        now = monotonic()
        if now < deadline:
            if stop.wait(deadline - now):
                return
            continue  # a wait may end a little early: look at the clock again
        if stop.is_set():
            return
        # Moved on before the call, as rcl does: the call's duration is part of the period.
        deadline = next_deadline(deadline, period, now)
        tick()
