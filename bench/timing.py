"""Side-by-side timing: cases run in turns and keep their best round, so load hits them alike."""

from __future__ import annotations

import timeit
from collections.abc import Callable
from typing import Any

ROUNDS = 7


def compare(
    title: str, cases: list[tuple[str, Callable[[], Any]]], *, budget_s: float = 0.05
) -> dict[str, float]:
    """Time ``cases`` round-robin; print ns/op and the ratio to the first case (the anchor)."""
    timers = []
    for name, func in cases:
        timer = timeit.Timer(func)
        number, elapsed = timer.autorange()
        per_round = max(1, int(number * budget_s / max(elapsed, 1e-9)))
        timers.append((name, timer, per_round))
    best = {name: float("inf") for name, _, _ in timers}
    for _ in range(ROUNDS):
        for name, timer, per_round in timers:
            best[name] = min(best[name], timer.timeit(per_round) / per_round * 1e9)
    anchor = cases[0][0]
    print(f"\n{title}  (anchor: {anchor})")
    print(f"  {'case':<56} {'ns/op':>14} {'ratio':>9}")
    for name, _ in cases:
        print(f"  {name:<56} {best[name]:>14,.0f} {best[name] / best[anchor]:>8.2f}x")
    return best
