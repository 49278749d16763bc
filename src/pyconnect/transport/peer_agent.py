"""``PeerAgent``: the base of a peer's agents (the ``CustomNode`` agent API without rclpy).

Every agent has ``name``, ``conn_name``, ``get()``, ``send()``, ``is_connected()``,
``last_error``/``error_count`` and ``describe``. Whatever user code or a codec raises is logged
on the ``pyconnect.transport`` logger (stderr unless configured) with the agent's name and the
traceback, kept in ``last_error``, and the next sample is handled.

``Inbox`` hands samples from zenoh's threads to one thread per agent: user callbacks never run
on zenoh's own threads (a callback that blocks, e.g. on a service call, would otherwise stall
the link its reply has to come through). It keeps the last ``depth`` samples (ROS keep-last
history) and counts what it had to drop, or with ``depth=None`` every item (a service's
requests: each one is a query that must get its one reply, as ROS services keep all requests).
Handlers may be ``async def`` (pyconnect.transport.async_handlers); timers keep rcl's schedule
(pyconnect.transport.periodic).
"""

from __future__ import annotations

import asyncio
import collections
import logging
import threading
import traceback
from collections.abc import Callable
from typing import Any, ClassVar, Generic, Protocol, TypeVar

import zenoh

from pyconnect.codecs.wire import WireCodec
from pyconnect.errors import PyconnectError
from pyconnect.ros.option_checks import period_problem
from pyconnect.transport.async_handlers import agent_loop, cancel_coroutine, settle
from pyconnect.transport.conversion import DecodeFunc, EncodeFunc, WireConversion
from pyconnect.transport.graph import Graph
from pyconnect.transport.periodic import run_every
from pyconnect.transport.ros_names import resolve_name

logger = logging.getLogger("pyconnect.transport")
DEFAULT_DEPTH = 10
"""The keep-last depth of a topic agent's queue when none is given (ROS's default)."""
ResponseFunc = Callable[..., Any]
_Item = TypeVar("_Item")


class Peer(Protocol):
    """What agents use of their ``pyconnect.transport.peer.Peer`` (kept apart: no import cycle)."""

    name: str
    namespace: str
    domain_id: int
    registry: Any
    session: zenoh.Session
    graph: Graph
    max_payload_bytes: int | None

    def entity_token(
        self, *, kind: str, name: str, type_name: str, type_hash: str, qos: str
    ) -> str: ...

    def wait_for_graph(self, condition: Callable[[], bool], deadline: float | None) -> bool: ...

    def ok(self) -> bool: ...

    def shutdown(self) -> None: ...


def reform_response(data: Any, *, error: str | None = None) -> Any:
    """``CustomNode``'s response contract: dicts get ``'isdone'``; failures carry ``'error'``."""
    if error is not None:
        base = dict(data) if isinstance(data, dict) else {}
        base.update(isdone=False, error=error)
        return base
    if isinstance(data, dict):
        return {**data, "isdone": True}
    return data


def absolute_name(conn_name: str, namespace: str, node_name: str, kind: str = "topic") -> str:
    """``conn_name`` resolved as rclpy resolves it for node ``node_name`` in ``namespace``:
    ``~`` and relative names expanded, rcl's rules checked (``RosNameError`` names the rule),
    so a peer's entities meet a ROS node's of the same ``conn_name``."""
    return resolve_name(conn_name, node_name, namespace, kind)


def name_kind(conn_type: str) -> str:
    """What an agent's ``conn_name`` names, in rcl's error words: topic, service or action."""
    for kind in ("service", "action"):
        if conn_type.startswith(kind):
            return kind
    return "topic"


class PeerAgent:
    """One connection of a ``Peer``."""

    conn_type: ClassVar[str] = ""
    names_an_entity: ClassVar[bool] = True
    """False for an agent whose ``conn_name`` is no ROS name (a timer): not resolved."""
    _warned_of_default = False

    def __init__(
        self,
        peer: Peer,
        *,
        conn_name: str,
        agent_name: str | None = None,
        type_name: str = "",
        response_func: ResponseFunc | None = None,
    ) -> None:
        self.peer = peer
        self.name = agent_name or conn_name
        self.conn_name = conn_name
        # A timer's conn_name only keys peer.agents: no ROS entity takes its name.
        self.topic = (
            conn_name
            if not self.names_an_entity
            else absolute_name(conn_name, peer.namespace, peer.name, name_kind(self.conn_type))
        )
        self.type_name = type_name
        self.response_func = response_func
        self.last_error: str | None = None
        self.error_count = 0
        self._latest: Any = None

    @property
    def describe(self) -> str:
        kind = f"{self.conn_type} {self.type_name}".strip()
        return f"agent {self.name!r} ({kind})"

    def wire_conversion(
        self,
        codec: WireCodec,
        *,
        encode_func: EncodeFunc | None = None,
        decode_func: DecodeFunc | None = None,
        raw: bool = False,
    ) -> WireConversion:
        """Values of ``codec``'s type to CDR and back, for this agent (its peer's registry)."""
        return WireConversion(
            describe=self.describe,
            codec=codec,
            registry=self.peer.registry,
            encode_func=encode_func,
            decode_func=decode_func,
            raw=raw,
        )

    def error(self, text: str) -> PyconnectError:
        return PyconnectError(f"{self.describe}: {text}")

    def get(self, show_info: bool = False) -> Any:
        """The latest value this agent handled; None before any."""
        if show_info:
            logger.info("%s: latest %r", self.describe, self._latest)
        return self._latest

    def send(self, data: Any = None) -> Any:
        raise self.error(f"send() is not available on a {self.conn_type!r} agent")

    def is_connected(self) -> bool:
        return True

    def waiting_for(self) -> str:
        return ""

    def why_no_answer(self, missing: str, timeout: float | None) -> str:
        """Why a wait ended without an answer: the peer's shutdown, or ``timeout``."""
        if not self.peer.ok():
            return f"peer {self.peer.name!r} is shut down"
        return f"{missing} within {timeout} s"

    def warn_of_default_answer(self, codec: WireCodec) -> None:
        """A server's ``response_func`` returned None, so the default of ``codec``'s type goes
        back: said once, where that answer has fields (a handler that forgot its ``return``
        answered success=False, or an empty result, without a word; std_srvs/Empty has nothing
        else to answer)."""
        if self._warned_of_default or not codec.to_dict(codec.from_dict({})):
            return
        self._warned_of_default = True
        logger.warning(
            "%s: response_func returned None: answering the default %s",
            self.describe,
            codec.msg_type,
        )

    def report_exception(self, where: str, error: BaseException) -> None:
        text = "".join(traceback.format_exception(type(error), error, error.__traceback__))
        # The agent's own errors (its conversion's DecodeError...) start with its name already.
        reason = str(error).removeprefix(f"{self.describe}: ")
        self.last_error = f"{self.describe}: {where} raised {type(error).__name__}: {reason}"
        self.error_count += 1
        logger.error("%s\n%s", self.last_error, text.rstrip())

    def exit_requested(self, where: str, error: BaseException) -> None:
        """A handler raised what ``except Exception`` misses: reported, and a ``sys.exit()``
        (or an interrupt) shuts the peer down, so ``spin()`` returns, as a ``CustomNode`` does;
        the agent's thread, which the exception would have ended without a word, goes on
        until the shutdown closes it."""
        if self.cancelled_by_shutdown(error):
            logger.info("%s: %s cancelled by the shutdown", self.describe, where)
            return
        self.report_exception(where, error)
        if isinstance(error, (SystemExit, KeyboardInterrupt)):  # not a CancelledError
            self.peer.shutdown()  # on an agent's thread: started in the background

    def cancelled_by_shutdown(self, error: BaseException) -> bool:
        """Whether ``error`` is an ``async def`` handler's cancellation by the peer's shutdown."""
        return isinstance(error, asyncio.CancelledError) and not self.peer.ok()

    def close(self) -> None:
        """Undeclare the zenoh entities (the peer calls this on shutdown)."""


class Inbox(Generic[_Item]):
    """Keep-last (or, ``depth=None``, keep-all) queue between zenoh's threads and one handler
    thread. ``discard(item)`` takes what arrives after ``close`` or is still waiting then."""

    def __init__(
        self,
        name: str,
        depth: int | None,
        handle: Callable[[_Item], None],
        *,
        discard: Callable[[_Item], None] | None = None,
    ) -> None:
        if depth is not None and depth < 1:
            raise PyconnectError(f"{name}: depth must be >= 1, got {depth!r}")
        self._items: collections.deque[_Item] = collections.deque(maxlen=depth)
        self._ready = threading.Condition(threading.Lock())
        self._handle = handle
        self._discard = discard
        self._closed = False
        self.dropped = 0
        self._thread = threading.Thread(target=self._run, name=f"pyconnect-{name}", daemon=True)
        self._thread.start()

    @property
    def waiting(self) -> int:
        """How many items wait for the handler now."""
        return len(self._items)

    @property
    def closed(self) -> bool:
        return self._closed

    def put(self, item: _Item) -> None:
        with self._ready:
            if not self._closed:
                if len(self._items) == self._items.maxlen:
                    self.dropped += 1
                self._items.append(item)
                self._ready.notify()
                return
        self._drop(item)

    def _run(self) -> None:
        with agent_loop():
            while True:
                with self._ready:
                    while not self._items and not self._closed:
                        self._ready.wait()
                    if self._closed:
                        return
                    item = self._items.popleft()
                try:
                    self._handle(item)
                except BaseException as error:  # the handlers report their own: the backstop
                    # (a SystemExit here would end the thread, and nothing would be handled)
                    logger.error(
                        "%s: handler raised %s: %s", self._thread.name, type(error).__name__, error
                    )
                del item  # a zenoh query is answered for good only when it is released

    def _drop(self, item: _Item) -> None:
        if self._discard is None:
            return
        try:
            self._discard(item)
        except Exception as error:  # the session may be closing under it: nothing to tell
            logger.debug(
                "%s: discard raised %s: %s", self._thread.name, type(error).__name__, error
            )

    def close(self, timeout: float = 5.0) -> None:
        with self._ready:
            self._closed = True
            self._ready.notify()
        if self._thread is not threading.current_thread():
            cancel_coroutine(self._thread)
            self._thread.join(timeout)
        with self._ready:
            left = list(self._items)
            self._items.clear()
        for item in left:
            self._drop(item)


class TimerAgent(PeerAgent):
    """Calls ``response_func()`` every ``time_period`` seconds on rcl's schedule (periodic);
    ``get()`` is its last return (an ``async def`` one's: what its coroutine returned)."""

    conn_type = "timer"
    names_an_entity = False

    def __init__(
        self,
        peer: Peer,
        *,
        conn_name: str,
        agent_name: str | None = None,
        time_period: float,
        response_func: ResponseFunc,
    ) -> None:
        super().__init__(peer, conn_name=conn_name, agent_name=agent_name)
        problem = period_problem(time_period)
        if problem is not None:
            raise self.error(problem)
        if response_func is None:
            raise self.error("a 'timer' agent needs a response_func")
        self._handler: ResponseFunc = response_func
        self.time_period = time_period
        self.tick_count = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(
            target=self._run, name=f"pyconnect-timer-{self.name}", daemon=True
        )
        self._thread.start()

    def _run(self) -> None:
        with agent_loop():
            run_every(self.time_period, self._stop, self._tick)

    def _tick(self) -> None:
        self.tick_count += 1
        try:
            self._latest = settle(self._handler())
        except Exception as error:
            self.report_exception("response_func", error)
        except BaseException as error:  # sys.exit() in the handler
            self.exit_requested("response_func", error)

    def close(self) -> None:
        self._stop.set()
        if self._thread is not threading.current_thread():
            cancel_coroutine(self._thread)
            self._thread.join(5.0)
