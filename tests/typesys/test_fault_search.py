"""Finding the line at fault by trying parts of a message: few tries, few lines in all."""

from __future__ import annotations

from collections.abc import Set

import pytest

from pyconnect.typesys.fault_search import line_at_fault


class _Message:
    """Lines [0, count) of which those in ``bad`` fail alone and ``pairs`` fail together."""

    def __init__(self, bad: Set[int], pairs: Set[tuple[int, int]] = frozenset()) -> None:
        self.bad, self.pairs = bad, pairs
        self.tries = 0
        self.lines = 0

    def fails(self, first: int, end: int) -> bool:
        self.tries += 1
        self.lines += end - first
        held = range(first, end)
        return any(n in held for n in self.bad) or any(
            a in held and b in held for a, b in self.pairs
        )


@pytest.mark.parametrize("bad", [0, 1, 499, 998, 999])
def test_a_line_failing_alone_costs_two_parses_of_the_message(bad: int) -> None:
    message = _Message({bad})
    assert line_at_fault(message.fails, 0, 1000) == bad + 1
    assert message.tries <= 2 * 10 + 1
    assert message.lines <= 2 * 1000


def test_the_earliest_of_several_faults_is_found() -> None:
    assert line_at_fault(_Message({700, 20, 300}).fails, 0, 1000) == 21


def test_a_fault_of_two_lines_is_bisected() -> None:
    message = _Message(set(), {(3, 900)})
    assert line_at_fault(message.fails, 0, 1000) == 901
    assert message.tries <= 3 * 10 + 1


def test_an_offset_part_and_a_failing_empty_message() -> None:
    assert line_at_fault(_Message({57}).fails, 50, 60) == 58
    assert line_at_fault(lambda first, end: True, 0, 10) is None
