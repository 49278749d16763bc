"""Agent option values checked when an agent is added, the same for ``CustomNode`` and ``Peer``.

A wrong value was taken and failed later, at every message or never visibly: a string given as
``response_func`` was logged as "not callable" once per message, ``raw=0`` meant the raw path,
``result_cache_seconds=-1`` answered no late result request, and a handler that cannot take the
arguments its agent calls it with failed at every call. No rclpy here: peers use it too.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from pyconnect.ros.agent_options import OptionError
from pyconnect.ros.handler_shape import wants_feedback_publisher
from pyconnect.ros.option_checks import arity_problem, plain_option_problem, seconds_problem

__all__ = ["FUNCTION_OPTIONS", "check_option_values", "handler_calls"]

FUNCTION_OPTIONS = ("encode_func", "decode_func", "response_func", "accepted_func", "feedback_func")
"""The options whose value is a function (or None)."""
_SECONDS_OPTIONS = ("result_timeout", "result_cache_seconds")


def check_option_values(kind: str | None, given: Mapping[str, Any], where: str) -> None:
    """Raise ``OptionError`` (starting with ``where``, naming the option) for the first value in
    ``given`` an agent of ``kind`` cannot use; ``kind`` None (an agent class of the user's)
    skips the handler shapes, which only the built-in kinds define."""
    for option in FUNCTION_OPTIONS:
        function = given.get(option)
        if function is not None and not callable(function):
            hint = "; pass the function itself, not its name" if isinstance(function, str) else ""
            raise OptionError(f"{where}: {option}: expected a callable, got {function!r}{hint}")
    for option, value in given.items():
        problem = plain_option_problem(option, value)
        if problem is not None:
            raise OptionError(f"{where}: {problem}")
    for option in _SECONDS_OPTIONS:
        if option in given:
            problem = seconds_problem(option, given[option])
            if problem is not None:
                raise OptionError(f"{where}: {problem}")
    for option, (count, calls) in handler_calls(kind, given).items():
        problem = arity_problem(given.get(option), count, calls)
        if problem is not None:
            raise OptionError(f"{where}: {option}: {problem}")


def handler_calls(kind: str | None, given: Mapping[str, Any]) -> dict[str, tuple[int, str]]:
    """How an agent of ``kind`` calls each handler option: {option: (positional arguments, in
    words)}, as the agent modules of both hosts call them."""
    if kind == "timer":
        return {"response_func": (0, "a timer calls it with no arguments")}
    if kind == "pub":
        if given.get("time_period") is None:  # the pub refuses a response_func without one
            return {}
        return {"response_func": (0, "a periodic pub calls it with no arguments")}
    if kind == "sub":
        return {"response_func": (1, "a sub calls it with one argument (the value)")}
    if kind == "service_server":
        return {"response_func": (1, "a service_server calls it with one argument (the request)")}
    if kind == "action_server":
        handler = given.get("response_func")
        if callable(handler) and wants_feedback_publisher(handler):
            calls = (
                "an action_server calls it with two arguments (the goal and publish_feedback, "
                "as it takes a second positional parameter)"
            )
            return {"response_func": (2, calls)}
        return {"response_func": (1, "an action_server calls it with one argument (the goal)")}
    if kind == "action_client":
        return {
            "response_func": (1, "an action_client calls it with one argument (the result)"),
            "accepted_func": (1, "an action_client calls it with one argument (accepted: bool)"),
            "feedback_func": (1, "an action_client calls it with one argument (the feedback)"),
        }
    return {}
