"""Timers and periodic publishers keep their rate: rcl's schedule, not the callback's end + period."""

from __future__ import annotations

import threading
import time

import pytest

from pyconnect.errors import PyconnectError
from pyconnect.transport import periodic
from tests.transport.conftest import PeerFactory

TIMEOUT = 30.0
PERIOD = 0.1
WORK = 0.05  # half the period: the old schedule made that a 0.15 s period
WINDOW = 3.2


class Ticks:
    """Times of a periodic callback that works ``WORK`` seconds; ``done`` once ``WINDOW`` is seen."""

    def __init__(self) -> None:
        self.times: list[float] = []
        self.done = threading.Event()
        self._busy = threading.Event()  # never set: waiting on it is the callback's work

    def __call__(self) -> str:
        now = time.monotonic()
        self.times.append(now)
        if now - self.times[0] >= WINDOW:
            self.done.set()
        self._busy.wait(WORK)
        return "x"

    def in_window(self) -> int:
        """Calls after the first within ``WINDOW`` seconds of it: 32 on schedule, 21 drifting."""
        first = self.times[0]
        return sum(1 for t in self.times[1:] if t - first <= WINDOW)


def test_a_timer_and_a_periodic_publisher_keep_their_rate(make_peer: PeerFactory) -> None:
    peer = make_peer("robot")
    timer, publisher = Ticks(), Ticks()
    peer.add_agent(conn_name="work", conn_type="timer", time_period=PERIOD, response_func=timer)
    peer.add_agent(
        conn_name="out",
        conn_type="pub",
        data_interface="std_msgs/msg/String",
        time_period=PERIOD,
        response_func=publisher,
    )
    assert timer.done.wait(TIMEOUT) and publisher.done.wait(TIMEOUT)
    # Generous for a loaded machine: a late call is skipped, never stretches the period.
    assert timer.in_window() >= 25
    assert publisher.in_window() >= 25


class FakeClock:
    """``monotonic`` and the stop event of ``run_every`` on a clock that only moves when told."""

    def __init__(self) -> None:
        self.now = 0.0
        self.stopped = False

    def monotonic(self) -> float:
        return self.now

    def wait(self, timeout: float) -> bool:
        self.now += timeout
        return self.stopped

    def is_set(self) -> bool:
        return self.stopped


@pytest.mark.parametrize(
    ("durations", "calls"),
    [
        # On time: every 0.1 s, whatever each call takes below a period.
        ([0.05] * 4, [0.1, 0.2, 0.3, 0.4]),
        # 0.25 s late: one call at once, then back on the 0.1 grid (0.2 and 0.3 are skipped).
        ([0.35, 0.0, 0.0], [0.1, 0.45, 0.5]),
        # Always late: back to back, never a burst of catch-up calls.
        ([0.15] * 3, [0.1, 0.25, 0.4]),
    ],
)
def test_late_calls_skip_the_deadlines_they_missed(
    monkeypatch: pytest.MonkeyPatch, durations: list[float], calls: list[float]
) -> None:
    clock = FakeClock()
    monkeypatch.setattr(periodic, "monotonic", clock.monotonic)
    started: list[float] = []

    def tick() -> None:
        started.append(round(clock.now, 6))
        clock.now += durations[len(started) - 1]
        clock.stopped = len(started) == len(durations)

    periodic.run_every(0.1, clock, tick)  # type: ignore[arg-type]
    assert started == calls


def test_next_deadline_moves_by_whole_periods() -> None:
    assert periodic.next_deadline(1.0, 0.5, 1.2) == 1.5
    assert periodic.next_deadline(1.0, 0.5, 2.6) == 3.0
    assert periodic.next_deadline(1.0, 0.5, 1.5) == 1.5


@pytest.mark.parametrize("period", [0, -1.0, float("nan"), float("inf"), "1", True], ids=repr)
@pytest.mark.parametrize("kind", ["timer", "pub"])
def test_a_period_that_is_not_a_finite_positive_number_is_refused(
    make_peer: PeerFactory, kind: str, period: object
) -> None:
    """A NaN period passed the old ``<= 0`` check and ran the callback flat out; inf ended the
    agent's thread (``OverflowError``) after add_agent had returned."""
    peer = make_peer("robot")
    options = {"data_interface": "std_msgs/msg/String"} if kind == "pub" else {}
    with pytest.raises(PyconnectError) as caught:
        peer.add_agent(
            conn_name="beat",
            conn_type=kind,
            time_period=period,
            response_func=lambda: "x",
            **options,
        )
    described = "pub std_msgs/msg/String" if kind == "pub" else kind
    assert str(caught.value) == (
        f"agent 'beat' ({described}): time_period must be a finite number of seconds > 0, "
        f"got {period!r}"
    )
    assert "beat" not in peer.agents
