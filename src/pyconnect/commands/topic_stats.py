"""The numbers ``topic hz`` and ``topic bw`` print, computed as ``ros2 topic hz/bw`` compute them.

``RateWindow`` (hz): each message's receipt time (ns, the node's clock) is kept as the interval
since the previous one, in a window of ``window`` intervals (ros2cli's default 10000); a report
is due when a message arrives at least 1 s after the last report, and gives the mean rate
(1 / mean interval), the min and max interval, their population standard deviation and the
window (the number of intervals)::

    average rate: 9.998
        min: 0.099s max: 0.101s std dev: 0.00049s window: 21

``BandwidthWindow`` (bw): each message's serialised size and monotonic receipt time, in a window
of ``window`` messages (default 100); every second it prints total bytes / (now - first time
in the window), and the mean, min and max size, in B, KB or MB (1000-based) chosen by the rate::

    1.32 KB/s from 100 messages
        Message size mean: 0.02 KB min: 0.02 KB max: 0.02 KB
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

__all__ = ["BandwidthReport", "BandwidthWindow", "RateReport", "RateWindow"]

HZ_WINDOW = 10000
BW_WINDOW = 100


@dataclass(frozen=True)
class RateReport:
    rate: float
    min_s: float
    max_s: float
    std_dev_s: float
    window: int

    def __str__(self) -> str:
        return (
            f"average rate: {self.rate:.3f}\n\tmin: {self.min_s:.3f}s max: {self.max_s:.3f}s "
            f"std dev: {self.std_dev_s:.5f}s window: {self.window}"
        )


class RateWindow:
    """Message intervals for ``topic hz``; ``add(now_ns)`` per message, ``report()`` when due."""

    def __init__(self, window: int = HZ_WINDOW) -> None:
        self.intervals: deque[int] = deque(maxlen=window)
        self.first_ns = -1
        self.last_ns = 0
        self.last_report_ns = 0

    def add(self, now_ns: int) -> None:
        if now_ns == 0:  # a simulated clock not started (or reset): start afresh
            self.intervals.clear()
            return
        if self.first_ns < 0 or self.first_ns > now_ns:
            self.first_ns = now_ns
            self.last_ns = now_ns
            self.intervals.clear()
            return
        self.intervals.append(now_ns - self.last_ns)
        self.last_ns = now_ns

    def report(self) -> RateReport | None:
        """The statistics, once per second of message time (None when not due)."""
        if not self.intervals:
            return None
        if self.last_report_ns == 0:
            self.last_report_ns = self.last_ns
            return None
        if self.last_ns < self.last_report_ns + 1_000_000_000:
            return None
        self.last_report_ns = self.last_ns
        return self.statistics()

    def statistics(self) -> RateReport | None:
        if not self.intervals:
            return None
        n = len(self.intervals)
        mean = sum(self.intervals) / n
        std_dev = math.sqrt(sum((x - mean) ** 2 for x in self.intervals) / n)
        return RateReport(
            rate=1e9 / mean if mean > 0 else 0.0,
            min_s=min(self.intervals) * 1e-9,
            max_s=max(self.intervals) * 1e-9,
            std_dev_s=std_dev * 1e-9,
            window=n,
        )


def _bytes_text(size: float, unit: str) -> str:
    if unit == "B":
        return f"{size:.0f} B"
    if unit == "KB":
        return f"{size / 1000:.2f} KB"
    return f"{size / 1000 / 1000:.2f} MB"


@dataclass(frozen=True)
class BandwidthReport:
    bytes_per_s: float
    messages: int
    mean: float
    min_size: int
    max_size: int

    def __str__(self) -> str:
        unit = "B" if self.bytes_per_s < 1000 else "KB" if self.bytes_per_s < 1_000_000 else "MB"
        return (
            f"{_bytes_text(self.bytes_per_s, unit)}/s from {self.messages} messages\n"
            f"\tMessage size mean: {_bytes_text(self.mean, unit)} "
            f"min: {_bytes_text(self.min_size, unit)} max: {_bytes_text(self.max_size, unit)}"
        )


class BandwidthWindow:
    """Sizes and monotonic times (s) for ``topic bw``; ``add`` per message, ``report(now)``."""

    def __init__(self, window: int = BW_WINDOW) -> None:
        self.times: deque[float] = deque(maxlen=window)
        self.sizes: deque[int] = deque(maxlen=window)

    def add(self, now_s: float, size: int) -> None:
        self.times.append(now_s)
        self.sizes.append(size)

    def report(self, now_s: float) -> BandwidthReport | None:
        if len(self.times) < 2:
            return None
        first = self.times[0]
        if now_s <= first:
            self.times.clear()
            self.sizes.clear()
            return None
        total = sum(self.sizes)
        n = len(self.sizes)
        return BandwidthReport(
            total / (now_s - first), n, total / n, min(self.sizes), max(self.sizes)
        )
