"""Checking an agent's options against its class, without rclpy: CustomNode's and Peer's rules.

An agent class lists the options it takes as its keyword-only ``__init__`` parameters
(``options_of``). ``check_options`` refuses a given option the class does not take with an
``OptionError`` naming it; ``shared_options`` keeps of ``add_agents(configs, **shared)`` only the
options a kind takes (shared options are defaults). Both hosts use them —
``pyconnect.ros.agent_factory`` for ``CustomNode`` and ``pyconnect.transport.peer`` for
``Peer`` — so this module imports nothing that imports rclpy. ``period_problem``,
``timeout_problem``, ``seconds_problem``, ``depth_problem``, ``plain_option_problem`` and
``arity_problem`` say what is wrong with one option's value (the agent names itself in the
error it raises).
"""

from __future__ import annotations

import inspect
import math
import numbers
import threading
from collections.abc import Mapping
from typing import Any

import numpy as np

from pyconnect.errors import PyconnectError
from pyconnect.ros.agent_options import AgentOptions, OptionError

KNOWN_OPTIONS = frozenset(AgentOptions.__annotations__)
"""Every option a ``CustomNode`` agent kind may take."""
NAMING = frozenset({"conn_name", "conn_type", "agent_name"})
"""The options that name an agent: every kind takes them."""
MAX_TIMEOUT = min((2**63 - 1) / 1e9, threading.TIMEOUT_MAX)
"""The longest timeout a wait takes, about 292 years: what int64 nanoseconds hold (rcl's waits
and timers, the CLI's ``MAX_SECONDS``) and no more than ``threading``'s waits accept
(``TIMEOUT_MAX``). Also the longest period and duration option (a Peer's timer waits it)."""


def options_of(agent_class: type[Any]) -> tuple[frozenset[str], frozenset[str]]:
    """(every option ``agent_class`` takes, the ones it requires), from its ``__init__``."""
    parameters = inspect.signature(agent_class.__init__).parameters.values()
    keywords = [p for p in parameters if p.kind is inspect.Parameter.KEYWORD_ONLY]
    return (
        frozenset(p.name for p in keywords),
        frozenset(p.name for p in keywords if p.default is inspect.Parameter.empty),
    )


def check_options(
    agent_class: type[Any],
    given: Mapping[str, Any],
    where: str,
    *,
    kind: str,
    known: frozenset[str] = KNOWN_OPTIONS,
    unavailable: Mapping[str, str] | None = None,
) -> None:
    """Raise ``OptionError`` for the first option in ``given`` that ``agent_class`` does not take,
    then for the first one it requires that is missing (``conn_name`` is checked by the caller).
    A required option given as None is missing too: a config built with ``.get()`` passed
    ``response_func=None`` to a timer, which then failed on every tick.

    ``known`` options are "not used by a '<kind>' agent"; ``unavailable`` maps an option the host
    offers to no kind at all to why ("option 'x' is not available on a peer: <why>"); any other
    name is unknown. Messages start with ``where``, e.g. ``agent 'cam' (sub)``.
    """
    accepted, required = options_of(agent_class)
    for option in given:
        if option in accepted:
            continue
        if unavailable is not None and option in unavailable:
            raise OptionError(f"{where}: option {option!r} {unavailable[option]}")
        if option in known:
            raise OptionError(f"{where}: option {option!r} is not used by a {kind!r} agent")
        raise OptionError(f"{where}: unknown option {option!r}")
    present = {option for option, value in given.items() if value is not None}
    for option in sorted(required - {"conn_name"} - present):
        raise OptionError(f"{where}: missing option {option!r}")


def shared_options(
    accepted: frozenset[str] | None,
    shared: Mapping[str, Any],
    *,
    known: frozenset[str] = KNOWN_OPTIONS,
) -> dict[str, Any]:
    """The ``shared`` options a kind that takes ``accepted`` uses (``None``: an unknown kind,
    which keeps them all). A ``known`` option the kind does not take is left out: shared options
    are defaults, so ``do_log_msg=True`` shared by subs and a timer skips the timer. Other names
    are kept, so that ``check_options`` still refuses them."""
    if accepted is None:
        return dict(shared)
    return {
        name: value
        for name, value in shared.items()
        if name in accepted or name in NAMING or name not in known
    }


def period_problem(time_period: object) -> str | None:
    """Why ``time_period`` cannot be an agent's period, or None when it can: a finite number of
    seconds above 0, at most ``MAX_TIMEOUT``. (A NaN passes ``<= 0`` and made a Peer's timer run
    flat out; inf ended its thread; rclpy raised its own error, naming no agent, and a bare
    ``TypeError`` for a period its int64 nanoseconds cannot hold.)"""
    problem = f"time_period must be a finite number of seconds > 0, got {time_period!r}"
    if isinstance(time_period, bool) or not isinstance(time_period, numbers.Real):
        return problem  # numpy's numbers are Real too
    seconds = float(time_period)
    if not (math.isfinite(seconds) and seconds > 0):
        return problem
    if seconds > MAX_TIMEOUT:
        return f"time_period must be at most {MAX_TIMEOUT:.3g} seconds, got {time_period!r}"
    return None


def seconds_problem(option: str, seconds: object) -> str | None:
    """Why ``seconds`` cannot be the duration ``option`` names, or None when it can: a finite
    number of seconds from 0 to ``MAX_TIMEOUT``. (An action server's ``result_timeout`` of -1
    or "0.5" failed inside rclpy naming neither agent nor option; a NaN or negative
    ``result_cache_seconds`` was taken and answered no late result request.)"""
    problem = f"{option} must be a finite number of seconds >= 0, got {seconds!r}"
    if isinstance(seconds, bool) or not isinstance(seconds, numbers.Real):
        return problem  # numpy's numbers are Real too
    value = float(seconds)
    if not (math.isfinite(value) and value >= 0):
        return problem
    if value > MAX_TIMEOUT:
        return f"{option} must be at most {MAX_TIMEOUT:.3g} seconds, got {seconds!r}"
    return None


def timeout_problem(timeout: object) -> str | None:
    """Why ``timeout`` cannot be a wait's timeout, or None when it can: None (wait for ever) or
    a finite number of seconds from 0 to ``MAX_TIMEOUT``. (A string passed the constructor and
    failed only in the deadline's arithmetic, after the request or goal had been sent; 1e10 s
    ended a client's watchdog of late answers with an ``OverflowError``.)"""
    if timeout is None:
        return None
    problem = f"timeout must be None or a finite number of seconds >= 0, got {timeout!r}"
    if isinstance(timeout, bool) or not isinstance(timeout, numbers.Real):
        return problem  # numpy's numbers are Real too
    seconds = float(timeout)
    if not (math.isfinite(seconds) and seconds >= 0):
        return problem
    if seconds > MAX_TIMEOUT:
        return (
            f"timeout must be at most {MAX_TIMEOUT:.3g} seconds (None waits for ever), "
            f"got {timeout!r}"
        )
    return None


def call_timeout(timeout: float | None, default: float | None, *, where: str) -> float | None:
    """The timeout one call waits: its own ``timeout``, else the agent's ``default``.

    Checked before anything is sent, raising ``PyconnectError`` that starts with ``where``
    (``agent 'x' (service_client ...): send``): a wrong one used to fail in the middle of the
    call, with the request or goal already out.
    """
    effective = default if timeout is None else timeout
    problem = timeout_problem(effective)
    if problem is not None:
        raise PyconnectError(f"{where}: {problem}")
    return effective


def depth_problem(depth: object) -> str | None:
    """Why ``depth`` cannot be a keep-last queue depth, or None when it can: an int >= 1, not a
    bool. (A peer's pub wrote any value into its liveliness token, which rmw_zenoh parses.)"""
    if isinstance(depth, bool) or not isinstance(depth, int):
        return f"depth must be an int >= 1, got {depth!r}"
    return None if depth >= 1 else f"depth must be >= 1, got {depth!r}"


_BOOL = (bool, np.bool_, type(None))
PLAIN_OPTIONS: Mapping[str, tuple[type, ...]] = {
    "agent_name": (str, type(None)),
    "do_log_msg": _BOOL,
    "only_if_subscribed": _BOOL,
    "stamped": _BOOL,
    "raw": _BOOL,
    "frame_id": (str, type(None)),
}
"""The options whose value is a plain bool or str, with the types each takes: None is the
default (a config built with ``.get()`` passes it), a numpy bool is a bool."""


def plain_option_problem(option: str, value: object) -> str | None:
    """Why ``value`` cannot be the ``PLAIN_OPTIONS`` ``option``, or None when it can (or the
    option is not one of them). Checked because Python's truth hid the mistake: "no" logged
    every message, ``raw=0`` meant the raw path, and ``frame_id=5`` failed at every send."""
    accepted = PLAIN_OPTIONS.get(option)
    if accepted is None or isinstance(value, accepted):
        return None
    names = {type(None): "None", np.bool_: ""}
    expected = " or ".join(filter(None, (names.get(kind, kind.__name__) for kind in accepted)))
    return f"{option}: expected {expected}, got {value!r}"


def arity_problem(function: object, count: int, calls: str) -> str | None:
    """Why ``function`` cannot be called with ``count`` positional arguments, or None when it
    can; ``calls`` says who calls it how ("a timer calls it with no arguments").

    What cannot be told is accepted: a callable without a readable signature (a builtin), and
    a decorated function whose own signature or the one it wraps takes the call.
    """
    if not callable(function):
        return None
    try:
        signatures = [
            inspect.signature(function),
            inspect.signature(function, follow_wrapped=False),
        ]
    except (TypeError, ValueError):  # builtins without a readable signature: let them run
        return None
    arguments = (None,) * count
    for signature in signatures:
        try:
            signature.bind(*arguments)
        except TypeError:
            continue
        return None
    parameters = signatures[0].parameters.values()
    if not any(p.kind is inspect.Parameter.VAR_POSITIONAL for p in parameters):
        positional = [
            p
            for p in parameters
            if p.kind
            in (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
        ]
        if len(positional) < count:
            takes = (
                f"only {len(positional)} positional argument{'s' if len(positional) > 1 else ''}"
                if positional
                else "no positional arguments"
            )
            return f"{calls}, but it takes {takes}"
    required = [
        p.name
        for p in parameters
        if p.default is inspect.Parameter.empty
        and p.kind not in (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)
    ]
    return f"{calls}, but it requires {', '.join(map(repr, required))}"
