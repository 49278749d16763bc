"""Checking an agent's options against its class, without rclpy: CustomNode's and Peer's rules.

An agent class lists the options it takes as its keyword-only ``__init__`` parameters
(``options_of``). ``check_options`` refuses a given option the class does not take with an
``OptionError`` naming it; ``shared_options`` keeps of ``add_agents(configs, **shared)`` only the
options a kind takes (shared options are defaults). Both hosts use them —
``pyconnect.ros.agent_factory`` for ``CustomNode`` and ``pyconnect.transport.peer`` for
``Peer`` — so this module imports nothing that imports rclpy. ``period_problem``,
``timeout_problem`` and ``depth_problem`` say what is wrong with one option's value (the agent
names itself in the error it raises).
"""

from __future__ import annotations

import inspect
import math
import numbers
import threading
from collections.abc import Mapping
from typing import Any

from pyconnect.errors import PyconnectError
from pyconnect.ros.agent_options import AgentOptions, OptionError

KNOWN_OPTIONS = frozenset(AgentOptions.__annotations__)
"""Every option a ``CustomNode`` agent kind may take."""
NAMING = frozenset({"conn_name", "conn_type", "agent_name"})
"""The options that name an agent: every kind takes them."""
MAX_TIMEOUT = min((2**63 - 1) / 1e9, threading.TIMEOUT_MAX)
"""The longest timeout a wait takes, about 292 years: what int64 nanoseconds hold (rcl's waits,
the CLI's ``MAX_SECONDS``) and no more than ``threading``'s waits accept (``TIMEOUT_MAX``)."""


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
    for option in sorted(required - {"conn_name"} - set(given)):
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
    seconds above 0. (A NaN passes ``<= 0`` and made a Peer's timer run flat out; inf ended its
    thread; rclpy raised its own error, naming no agent.)"""
    problem = f"time_period must be a finite number of seconds > 0, got {time_period!r}"
    if isinstance(time_period, bool) or not isinstance(time_period, numbers.Real):
        return problem  # numpy's numbers are Real too
    seconds = float(time_period)
    return None if math.isfinite(seconds) and seconds > 0 else problem


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
