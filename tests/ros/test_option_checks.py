"""The checks of one option's value that CustomNode's and Peer's agents share (no rclpy)."""

from __future__ import annotations

import fractions
import math
import threading

import numpy as np
import pytest

from pyconnect.commands.argument_types import MAX_SECONDS
from pyconnect.errors import PyconnectError
from pyconnect.ros.option_checks import (
    MAX_TIMEOUT,
    call_timeout,
    depth_problem,
    timeout_problem,
)

TIMEOUT_WORDS = "timeout must be None or a finite number of seconds >= 0, got"


@pytest.mark.parametrize(
    "timeout", [None, 0, 0.0, 2, 2.5, np.float64(1.5), fractions.Fraction(1, 2)]
)
def test_a_timeout_is_none_or_a_finite_number_of_seconds(timeout: object) -> None:
    assert timeout_problem(timeout) is None


@pytest.mark.parametrize(
    ("timeout", "shown"),
    [
        ("5", "'5'"),
        (-1, "-1"),
        (-0.5, "-0.5"),
        (math.nan, "nan"),
        (math.inf, "inf"),
        (True, "True"),
        (False, "False"),
        ([1.0], "[1.0]"),
    ],
)
def test_any_other_timeout_is_refused_naming_it(timeout: object, shown: str) -> None:
    assert timeout_problem(timeout) == f"{TIMEOUT_WORDS} {shown}"


def test_a_timeout_longer_than_any_wait_can_take_is_refused() -> None:
    """1e10 s passed, then ended a client's watchdog of late answers: threading's waits raise
    ``OverflowError`` past ``TIMEOUT_MAX``, so every later call's timeout went unheeded."""
    assert MAX_TIMEOUT <= threading.TIMEOUT_MAX
    assert MAX_TIMEOUT <= MAX_SECONDS  # the CLI's bound, int64 nanoseconds
    assert MAX_TIMEOUT > 9e9  # about 292 years: every real timeout still passes
    assert timeout_problem(MAX_TIMEOUT) is None
    too_long = f"timeout must be at most {MAX_TIMEOUT:.3g} seconds (None waits for ever), got"
    assert timeout_problem(1e10) == f"{too_long} 10000000000.0"
    assert timeout_problem(10**30) == f"{too_long} {10**30}"
    with pytest.raises(PyconnectError) as raised:
        call_timeout(1e10, None, where="agent 'a': send")
    assert str(raised.value) == f"agent 'a': send: {too_long} 10000000000.0"


def test_a_call_waits_its_own_timeout_else_the_agents() -> None:
    assert call_timeout(None, None, where="agent 'a'") is None
    assert call_timeout(None, 3.0, where="agent 'a'") == 3.0
    assert call_timeout(1.0, 3.0, where="agent 'a'") == 1.0
    assert call_timeout(0, None, where="agent 'a'") == 0


def test_a_call_refuses_a_wrong_timeout_naming_where_and_the_value() -> None:
    with pytest.raises(PyconnectError) as raised:
        call_timeout("2", 3.0, where="agent 'a' (service_client x/srv/Y): send")  # type: ignore[arg-type]
    assert str(raised.value) == f"agent 'a' (service_client x/srv/Y): send: {TIMEOUT_WORDS} '2'"
    # The agent's own timeout is checked too (it may have been set after the agent was made).
    with pytest.raises(PyconnectError) as raised:
        call_timeout(None, -1.0, where="agent 'a': send")
    assert str(raised.value) == f"agent 'a': send: {TIMEOUT_WORDS} -1.0"


@pytest.mark.parametrize("depth", [1, 10, 2**31 - 1])
def test_a_depth_is_an_int_of_at_least_one(depth: int) -> None:
    assert depth_problem(depth) is None


@pytest.mark.parametrize(
    ("depth", "problem"),
    [
        (0, "depth must be >= 1, got 0"),
        (-1, "depth must be >= 1, got -1"),
        (True, "depth must be an int >= 1, got True"),
        ("abc", "depth must be an int >= 1, got 'abc'"),
        ("10", "depth must be an int >= 1, got '10'"),
        (2.5, "depth must be an int >= 1, got 2.5"),
        (None, "depth must be an int >= 1, got None"),
    ],
)
def test_any_other_depth_is_refused_naming_it(depth: object, problem: str) -> None:
    assert depth_problem(depth) == problem
