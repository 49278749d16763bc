"""The checks of one option's value that CustomNode's and Peer's agents share (no rclpy)."""

from __future__ import annotations

import fractions
import functools
import math
import threading
from typing import Any

import numpy as np
import pytest

from pyconnect.commands.argument_types import MAX_SECONDS
from pyconnect.errors import PyconnectError
from pyconnect.ros.agent_options import OptionError
from pyconnect.ros.option_checks import (
    MAX_TIMEOUT,
    arity_problem,
    call_timeout,
    check_options,
    depth_problem,
    period_problem,
    plain_option_problem,
    seconds_problem,
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


def test_a_period_longer_than_a_timer_holds_is_refused() -> None:
    """1e10 s reached rclpy, whose int64 nanoseconds cannot hold it: a bare pybind TypeError."""
    assert period_problem(MAX_TIMEOUT) is None
    assert period_problem(0.01) is None
    too_long = f"time_period must be at most {MAX_TIMEOUT:.3g} seconds, got"
    assert period_problem(1e10) == f"{too_long} 10000000000.0"
    assert period_problem(10**30) == f"{too_long} {10**30}"


@pytest.mark.parametrize("seconds", [0, 0.05, 900, np.float64(1.5), fractions.Fraction(1, 2)])
def test_a_duration_is_a_finite_number_of_seconds(seconds: object) -> None:
    assert seconds_problem("result_timeout", seconds) is None


@pytest.mark.parametrize(
    ("seconds", "problem"),
    [
        (-1, "result_timeout must be a finite number of seconds >= 0, got -1"),
        ("0.5", "result_timeout must be a finite number of seconds >= 0, got '0.5'"),
        (math.nan, "result_timeout must be a finite number of seconds >= 0, got nan"),
        (math.inf, "result_timeout must be a finite number of seconds >= 0, got inf"),
        (None, "result_timeout must be a finite number of seconds >= 0, got None"),
        (True, "result_timeout must be a finite number of seconds >= 0, got True"),
        (1e10, f"result_timeout must be at most {MAX_TIMEOUT:.3g} seconds, got 10000000000.0"),
    ],
)
def test_any_other_duration_is_refused_naming_the_option(seconds: object, problem: str) -> None:
    assert seconds_problem("result_timeout", seconds) == problem


@pytest.mark.parametrize(
    ("option", "value"),
    [
        ("do_log_msg", True),
        ("only_if_subscribed", False),
        ("stamped", True),
        ("raw", None),
        ("raw", False),
        ("frame_id", ""),
        ("frame_id", "map"),
        ("agent_name", None),
        ("agent_name", "left"),
        # None is the default (a config built with .get() passes it), a numpy bool a bool.
        ("do_log_msg", None),
        ("only_if_subscribed", None),
        ("stamped", None),
        ("frame_id", None),
        ("do_log_msg", np.bool_(True)),
        ("raw", np.bool_(False)),
        ("qos", "sensor"),  # not a plain option: checked elsewhere
        ("time_period", "x"),
    ],
)
def test_plain_options_take_their_bool_or_str(option: str, value: object) -> None:
    assert plain_option_problem(option, value) is None


@pytest.mark.parametrize(
    ("option", "value", "problem"),
    [
        ("do_log_msg", "no", "do_log_msg: expected bool or None, got 'no'"),
        ("do_log_msg", 1, "do_log_msg: expected bool or None, got 1"),
        ("only_if_subscribed", "no", "only_if_subscribed: expected bool or None, got 'no'"),
        ("stamped", "yes", "stamped: expected bool or None, got 'yes'"),
        ("raw", 0, "raw: expected bool or None, got 0"),
        ("frame_id", 5, "frame_id: expected str or None, got 5"),
        ("agent_name", 5, "agent_name: expected str or None, got 5"),
    ],
)
def test_plain_options_of_another_type_are_refused(
    option: str, value: object, problem: str
) -> None:
    """Truthy strings flipped the behaviour, raw=0 turned the raw path on (``raw is False``
    missed it) and frame_id=5 failed at every send."""
    assert plain_option_problem(option, value) == problem


def _one(value: Any) -> Any:
    return value


def _two(value: Any, other: Any) -> Any:
    return value


def _logged(function: Any) -> Any:
    @functools.wraps(function)
    def wrapper(*args: Any, **named: Any) -> Any:
        return function(*args, **named)

    return wrapper


def _injecting(function: Any) -> Any:
    # Wraps a two-parameter function and fills its second itself: its own signature says one.
    @functools.wraps(function)
    def wrapper(value: Any) -> Any:
        return function(value, None)

    return wrapper


class _Handler:
    def __call__(self, value: Any) -> Any:
        return value

    def on_value(self, value: Any) -> Any:
        return value


async def _async_one(value: Any) -> Any:
    return value


@pytest.mark.parametrize(
    "function",
    [
        _one,
        lambda value: value,
        lambda *args: args,
        lambda value, extra=1: value,
        functools.partial(_two, other=2),
        functools.partial(_two, 1),
        _Handler(),
        _Handler().on_value,
        _async_one,
        _logged(_one),
        _injecting(_two),
        _logged(_two),  # its (*args, **named) may fill 'other' itself, as _injecting does
        print,  # no readable signature: let it run
        "not callable",  # refused elsewhere, as not callable
    ],
)
def test_a_handler_that_takes_one_argument_is_accepted(function: object) -> None:
    assert arity_problem(function, 1, "a sub calls it with one argument") is None


@pytest.mark.parametrize(
    ("function", "count", "problem"),
    [
        (lambda: 1, 1, "it calls it with one argument, but it takes no positional arguments"),
        (
            lambda **named: 1,
            1,
            "it calls it with one argument, but it takes no positional arguments",
        ),
        (_one, 2, "it calls it with one argument, but it takes only 1 positional argument"),
        (_two, 1, "it calls it with one argument, but it requires 'value', 'other'"),
        (_one, 0, "it calls it with one argument, but it requires 'value'"),
        (
            lambda value, *, unit: value,
            1,
            "it calls it with one argument, but it requires 'value', 'unit'",
        ),
    ],
)
def test_a_handler_that_cannot_take_the_call_is_refused_naming_what_it_needs(
    function: object, count: int, problem: str
) -> None:
    assert arity_problem(function, count, "it calls it with one argument") == problem


class _Timer:
    def __init__(self, *, time_period: float, response_func: Any) -> None:
        pass


def test_a_required_option_given_as_none_is_missing() -> None:
    """A config built with ``.get()`` gave a timer response_func=None: accepted, then every
    tick failed."""
    for given in ({"time_period": 1.0}, {"time_period": 1.0, "response_func": None}):
        with pytest.raises(OptionError) as raised:
            check_options(_Timer, given, "agent 't' (timer)", kind="timer")
        assert str(raised.value) == "agent 't' (timer): missing option 'response_func'"
    check_options(_Timer, {"time_period": 1.0, "response_func": print}, "x", kind="timer")
