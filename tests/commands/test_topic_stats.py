"""``topic hz`` and ``topic bw`` numbers: ros2cli's formulas on known arrival times."""

from __future__ import annotations

from pyconnect.commands.topic_stats import BandwidthWindow, RateWindow

S = 1_000_000_000


def test_rate_reports_once_a_second_with_ros2cli_numbers() -> None:
    window = RateWindow()
    reports = []
    # arrivals every 0.1 s, except one 0.2 s gap
    stamps = [S + k * S // 10 for k in range(12)] + [S + 13 * S // 10, S + 14 * S // 10]
    for stamp in stamps:
        window.add(stamp)
        report = window.report()
        if report is not None:
            reports.append(str(report))
    # the first report is due 1 s after the first interval was recorded (at 1.1 s): at 2.1 s
    assert reports == [
        "average rate: 10.000\n\tmin: 0.100s max: 0.100s std dev: 0.00000s window: 11",
    ]
    final = window.statistics()
    assert final is not None
    # intervals: twelve of 0.1 s and one of 0.2 s (mean 0.1077 s)
    assert str(final) == (
        "average rate: 9.286\n\tmin: 0.100s max: 0.200s std dev: 0.02665s window: 13"
    )


def test_rate_window_keeps_the_last_intervals() -> None:
    window = RateWindow(window=2)
    for stamp in (S, 2 * S, 4 * S, 5 * S):
        window.add(stamp)
    report = window.statistics()
    assert report is not None
    assert (report.window, report.min_s, report.max_s) == (2, 1.0, 2.0)


def test_bandwidth_is_bytes_over_the_window_time_in_ros2cli_units() -> None:
    window = BandwidthWindow()
    for k in range(10):
        window.add(100.0 + k * 0.1, 1500)
    report = window.report(101.0)
    assert str(report) == (
        "15.00 KB/s from 10 messages\n\tMessage size mean: 1.50 KB min: 1.50 KB max: 1.50 KB"
    )
    small = BandwidthWindow(window=3)
    for k, size in enumerate((10, 20, 30, 40)):
        small.add(float(k), size)
    assert str(small.report(4.0)) == (
        "30 B/s from 3 messages\n\tMessage size mean: 30 B min: 20 B max: 40 B"
    )
    assert BandwidthWindow().report(1.0) is None
