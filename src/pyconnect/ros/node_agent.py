"""``NodeAgent``: the base of every agent kind (one ROS entity plus its codec, callbacks and log).

An agent kind subclasses it, sets ``conn_type`` and registers in ``AGENT_CLASS_DICT``
(``pyconnect.ros.agent_factory``). The base gives every kind the same ``get``/``send``/
``log_msg``/``reform_response``/``make_log_dirs`` and one rule for user code: whatever a
``response_func``, codec or user function raises is logged with the agent's name and the
traceback, kept in ``last_error``, and the executor goes on with the next message.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import concurrent.futures
import inspect
import threading
import traceback
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any, ClassVar

from rclpy.callback_groups import CallbackGroup, MutuallyExclusiveCallbackGroup

from pyconnect.codecs.base import Codec
from pyconnect.codecs.codec_checks import codec_problem
from pyconnect.errors import PyconnectError
from pyconnect.ros.agent_host import AgentHost
from pyconnect.ros.conversion import DecodeFunc, EncodeFunc, MessageConversion
from pyconnect.ros.coroutines import CoroutineExit, CoroutineLane, is_async_callable
from pyconnect.ros.interfaces import interface_name
from pyconnect.ros.log_snapshot import snapshot

ResponseFunc = Callable[..., Any]


class CancelledByShutdown(PyconnectError):
    """An ``async def`` handler was cancelled because its node shut down."""


class NodeAgent:
    """One connection of a ``CustomNode``: a publisher, subscriber, service, action or timer."""

    conn_type: ClassVar[str] = ""
    """The ``conn_type`` string that makes this kind (``'pub'``, ``'sub'``, ...)."""
    _warned_of_default = False

    def __init__(
        self,
        node: AgentHost,
        *,
        conn_name: str,
        agent_name: str | None = None,
        data_interface: object = None,
        response_func: ResponseFunc | None = None,
        do_log_msg: bool = False,
        callback_group: CallbackGroup | None = None,
    ) -> None:
        self.node = node
        """The host node, seen through ``AgentHost`` (what an agent may use of it)."""
        self.name = agent_name or conn_name
        """The key in ``node.agents``: ``agent_name`` when given (two agents on one topic)."""
        self.conn_name = conn_name
        self.data_interface = data_interface
        self.response_func = response_func
        self.do_log_msg = do_log_msg
        self.callback_group: CallbackGroup = callback_group or MutuallyExclusiveCallbackGroup()
        self.last_error: str | None = None
        """The last error a callback of this agent raised, with its traceback."""
        self.error_count = 0
        self._latest: Any = None
        self._log_dir: Path | None = None
        self._message_logger: Any = None
        self._log_failure: Exception | None = None
        self._log_lock = threading.Lock()
        # True while the latest value is an image with RGB(A) channels (PNG logs want BGR).
        self._log_rgb = False
        self._lane: CoroutineLane | None = None
        self._async_memo: tuple[object, bool] = (None, False)

    # -- identity ------------------------------------------------------------------------------
    @property
    def type_name(self) -> str:
        """``pkg/ns/Name`` of the agent's interface (empty for timers)."""
        if self.data_interface is None:
            return ""
        return interface_name(self.data_interface)

    @property
    def describe(self) -> str:
        """How errors name the agent: ``agent 'cmd_vel' (pub geometry_msgs/msg/Twist)``."""
        kind = f"{self.conn_type} {self.type_name}".strip()
        return f"agent {self.name!r} ({kind})"

    def make_conversion(
        self,
        msg_class: type,
        *,
        encode_func: EncodeFunc | None = None,
        decode_func: DecodeFunc | None = None,
        codec: Codec | None = None,
        eager: bool = False,
    ) -> MessageConversion:
        """How this agent converts ``msg_class``: the user's functions, else ``codec``, else the
        registry's codec.

        ``eager`` looks the codec up now, so that a type without one fails when the agent is
        created instead of at its first message (pass it for the directions the agent uses).
        """
        registry = self.node.registry
        if codec is not None:
            problem = codec_problem(codec)
            if problem is not None:
                raise self.error(f"codec: {problem}")
            # A codec of another type failed only at the first send, in rclpy's words.
            wanted, own = registry.resolve(msg_class), _resolved(registry, codec.msg_type)
            if own != wanted:
                raise self.error(
                    f"codec: {type(codec).__name__} converts {codec.msg_type!r}, "
                    f"expected a codec of {wanted!r}"
                )
        conversion = MessageConversion(
            describe=self.describe,
            msg_class=msg_class,
            codec_of=(lambda: codec)
            if codec is not None
            else (lambda: registry.lookup_message(msg_class)),
            encode_func=encode_func,
            decode_func=decode_func,
        )
        if eager:
            _ = conversion.codec
        return conversion

    def error(self, text: str) -> PyconnectError:
        """A ``PyconnectError`` whose message starts with this agent's name."""
        return PyconnectError(f"{self.describe}: {text}")

    # -- the common API ------------------------------------------------------------------------
    def get(self, show_info: bool = False) -> Any:
        """The latest value this agent handled (received, sent or returned); None before any."""
        if show_info:
            self.node.get_logger().info(self.info_text())
        return self._latest

    def send(self, data: Any = None) -> Any:
        """Send ``data`` (publish, call, send a goal); kinds that cannot send raise."""
        raise self.error(f"send() is not available on a {self.conn_type!r} agent")

    async def send_async(self, data: Any = None) -> Any:
        """``await agent.send_async(data)``: ``send`` for code running on an asyncio loop.

        Kinds whose ``send`` waits (service and action clients) wait without blocking the loop.
        """
        return self.send(data)

    def info_text(self) -> str:
        """A one-line summary of the agent and its latest value, for ``get(show_info=True)``."""
        return f"{self.describe}: latest {_summary(self._latest)}"

    def is_connected(self) -> bool:
        """Whether the agent has what ``wait_until_connected`` waits for."""
        return True

    @staticmethod
    def reform_response(data: Any, *, error: str | None = None) -> Any:
        """The design's response contract: dicts carry ``'isdone'``, failures an ``'error'`` text.

        Success: a dict gets ``'isdone': True`` (a copy; other values are returned as they
        are). Failure (timeout, abort, cancel, rejection): ``{'isdone': False, 'error': error}``,
        plus the fields of ``data`` when it is a dict (an aborted action's partial result).
        """
        if error is not None:
            base = dict(data) if isinstance(data, dict) else {}
            base.update(isdone=False, error=error)
            return base
        if isinstance(data, dict):
            return {**data, "isdone": True}
        return data

    # -- logging -------------------------------------------------------------------------------
    def make_log_dirs(self) -> Path:
        """This agent's log directory (``<root>/<node>/<session>/<agent>/``), created once."""
        with self._log_lock:
            if self._log_dir is None:
                self._log_dir = self.node.agent_log_dir(self.name)
            return self._log_dir

    def log_msg(self, data: Any, *, stamp_ns: int | None = None) -> bool:
        """Write ``data`` as it is now to this agent's log; never blocks or raises.

        False when the queue is full, or when the log folder cannot be made (reported once).
        The value is copied first (arrays, dicts, lists): files are written on another thread,
        while the caller goes on, e.g. draws on the image it received or refills the frame
        buffer it sent.
        """
        logger = self._message_logger
        if logger is None:
            logger = self._open_message_log()
            if logger is None:
                return False
        if logger.pending < logger.queue_size:  # a full queue drops it: no copy for nothing
            data = snapshot(data)
        ok: bool = logger.log(data, stamp_ns=stamp_ns, rgb=self._log_rgb)
        return ok

    def _open_message_log(self) -> Any:
        with self._log_lock:
            if self._message_logger is None and self._log_failure is None:
                from pyconnect.record.log_writer import MessageLogger

                try:
                    directory = self._log_dir or self.node.agent_log_dir(self.name)
                    # Writing fails later too (the folder removed, a full disk): the first
                    # failure of each kind becomes the agent's error, the rest are counted.
                    self._message_logger = MessageLogger(
                        directory, on_error=self._report_log_failure
                    )
                except Exception as error:  # e.g. a read-only disk: the agent still works
                    self._log_failure = error
                    self.report_exception("log_msg", error)
                    return None
                self._log_dir = directory
            return self._message_logger

    def _report_log_failure(self, error: Exception) -> None:
        """A logged value was not written (called on the log writer's thread)."""
        self.report_exception("log_msg", error)

    def _note_channel_order(self, msg: Any) -> None:
        """Remember whether ``msg`` is an image whose decoded pixels are RGB(A)."""
        encoding = getattr(msg, "encoding", None)
        self._log_rgb = isinstance(encoding, str) and encoding.startswith("rgb")

    def flush_log(self, timeout: float | None = None) -> bool:
        """Wait until the logged messages are on disk."""
        logger = self._message_logger
        if logger is None:
            return True
        flushed: bool = logger.flush(timeout=timeout)
        return flushed

    # -- user code -----------------------------------------------------------------------------
    def why_no_answer(self, missing: str, timeout: float | None, *, during: str = "call") -> str:
        """Why a blocking wait ended without an answer: the node's shutdown, or ``timeout``."""
        if self.node.shutdown_event.is_set():
            return f"node {self.node.qualified_name!r} shut down during the {during}"
        return f"{missing} within {timeout} s"

    def warn_of_default_answer(self, answer_class: type) -> None:
        """A server's ``response_func`` returned None, so the default ``answer_class`` goes
        back: said once, where that answer has fields (a handler that forgot its ``return``
        answered success=False, or an empty result, without a word; std_srvs/Empty has nothing
        else to answer)."""
        if self._warned_of_default or not answer_class.get_fields_and_field_types():
            return
        self._warned_of_default = True
        self.node.get_logger().warning(
            f"{self.describe}: response_func returned None: answering the default "
            f"{interface_name(answer_class)}"
        )

    def report_exception(self, where: str, error: BaseException) -> None:
        """Log an exception raised by user code or a codec, with the agent name and traceback."""
        if isinstance(error, CancelledByShutdown):
            # Not a failure of user code: the node stopped while the handler was running.
            self.node.get_logger().warning(f"{self.describe}: {where} cancelled by shutdown")
            return
        text = "".join(traceback.format_exception(type(error), error, error.__traceback__))
        self.last_error = f"{self.describe}: {where} raised {type(error).__name__}: {error}"
        self.error_count += 1
        self.node.get_logger().error(f"{self.last_error}\n{text.rstrip()}")

    def is_async(self, function: Callable[..., Any]) -> bool:
        """``is_async_callable(function)``, remembered for the last function asked about.

        Handlers are called per message: ``inspect`` costs tens of microseconds on a cold
        cache (bench/agents.py), the identity check next to nothing.
        """
        checked, answer = self._async_memo  # one tuple: threads never see a mixed pair
        if function is checked:
            return answer
        answer = is_async_callable(function)
        self._async_memo = (function, answer)
        return answer

    def call_user(
        self,
        where: str,
        function: Callable[..., Any],
        *args: Any,
        on_done: Callable[[Any], None] | None = None,
    ) -> None:
        """Call user code without ever raising: errors are reported with ``where``.

        An ``async def`` function runs on the node's coroutine loop, after this agent's earlier
        coroutines (pyconnect.ros.coroutines); ``on_done(result)`` follows a successful call.
        """
        if self.is_async(function):
            self.lane.submit(
                function,
                args,
                on_done=_reporting(self, where, on_done),
                on_error=lambda error: self.report_exception(where, error),
            )
            return
        try:
            result = function(*args)
            if on_done is not None:
                on_done(result)
        except Exception as error:
            self.report_exception(where, error)

    def _exit_from_coroutine(self, _error: BaseException) -> None:
        """An ``async def`` handler called ``sys.exit()`` (already reported): shut the node down,
        as a plain handler's does (pyconnect.ros.agent_executor)."""
        # On a thread of its own: this is the loop's thread, which shutdown stops and joins.
        threading.Thread(
            target=self.node.shutdown, name="pyconnect-exit-shutdown", daemon=True
        ).start()

    def refuse_to_block_on_loop(self, call: str) -> None:
        """Raise when this thread runs the node's coroutine loop: a blocking ``call`` there
        waits for an answer that may need that very loop (an ``async def`` handler's), so it
        would time out or wait for ever, and the loop with it."""
        if self.node.coroutines.on_loop_thread():
            raise self.error(
                f"{call} blocks, and was called on the thread of the node's asyncio loop, which "
                "the answer may need: use `await agent.send_async(...)` there instead"
            )

    def call_user_and_wait(self, function: Callable[..., Any], *args: Any) -> Any:
        """Call ``function`` and return its result; an ``async def`` one is awaited on the
        coroutine loop while this thread waits (handing the executor's turn on). Raises what
        the function raised."""
        if not self.is_async(function):
            return function(*args)
        return self.wait_on_loop(function(*args))

    def wait_on_loop(self, awaitable: Awaitable[Any]) -> Any:
        """Run ``awaitable`` on the coroutine loop and wait for its result here (handing the
        executor's turn on); raises what it raised (its ``sys.exit()`` too). On the loop's own
        thread, which alone could run it, raises a ``PyconnectError`` instead."""
        if self.node.coroutines.on_loop_thread():
            if inspect.iscoroutine(awaitable):
                awaitable.close()  # never awaited, and no warning saying so
            raise self.error(
                "waiting for a coroutine on the thread of the asyncio loop that must run it "
                "would never end: await it instead"
            )
        future = self.node.coroutines.submit(awaitable)
        finished = threading.Event()
        future.add_done_callback(lambda _future: finished.set())
        self.node.wait_for(finished, None, poll=future.done)
        # wait_for also returns when the node stops: the coroutine's result is not awaited then.
        future.cancel()
        try:
            return future.result()
        except concurrent.futures.CancelledError:
            raise CancelledByShutdown("the coroutine was cancelled (the node shuts down)") from None
        except CoroutineExit as exit_:
            # Here, on an executor's thread, it shuts the node down as a plain handler's would.
            raise exit_.error from None

    @property
    def lane(self) -> CoroutineLane:
        """This agent's ordered lane on the coroutine loop (made on first use)."""
        if self._lane is None:
            self._lane = self.node.coroutines.lane(on_exit=self._exit_from_coroutine)
        return self._lane

    # -- life cycle ----------------------------------------------------------------------------
    def close(self) -> None:
        """Destroy the ROS entities and close the log (the node calls this on shutdown)."""
        logger = self._message_logger
        if logger is not None:
            logger.close()


def _reporting(
    agent: NodeAgent, where: str, on_done: Callable[[Any], None] | None
) -> Callable[[Any], None] | None:
    """``on_done`` with its errors reported under ``where`` (the lane reports the call's)."""
    if on_done is None:
        return None

    def done(result: Any) -> None:
        try:
            on_done(result)
        except Exception as error:
            agent.report_exception(where, error)

    return done


def _summary(value: Any) -> str:
    if value is None:
        return "None (nothing yet)"
    shape = getattr(value, "shape", None)
    if shape is not None:
        return f"{type(value).__name__} shape={tuple(shape)} dtype={getattr(value, 'dtype', '?')}"
    text = repr(value)
    return text if len(text) <= 200 else text[:197] + "..."


def _resolved(registry: Any, msg_type: object) -> str | None:
    try:
        name: str = registry.resolve(msg_type)
    except PyconnectError:
        return None
    return name
