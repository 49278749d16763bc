"""``service_server`` and ``service_client`` agents.

Server: ``response_func(request_value) -> response_value`` (an ``async def`` one is awaited on
the node's coroutine loop while the executor goes on with other agents). A handler (or codec)
that raises still answers: a response type with ``success``/``message`` fields gets
``success=False`` and the error text, any other the default response; the error is logged with
the agent's name. A handler's ``sys.exit()`` is answered so too, then the node shuts down. At
shutdown (``close``) the requests that arrived but were never handled are answered
``success=False``, ``"server is shutting down"`` where the response type has a text field;
other types stay unanswered (a default response would read as a real answer), and their
clients time out.

Client: ``send(data, timeout=None)`` blocks and returns the decoded response through
``reform_response`` (dicts get ``'isdone': True``); on timeout, or when no server appears in
time, it returns ``{'isdone': False, 'error': ...}``. ``block=False`` returns a
``concurrent.futures.Future`` of the same value. Blocking is safe inside another agent's plain
callback: the executor passes its turn on while this thread waits (pyconnect.ros.executor).
``await send_async(data, timeout=None)`` is the same call for code on an asyncio loop; there (an
``async def`` handler, a coroutine on ``CustomNode(loop=...)``'s loop) a blocking ``send`` raises
a ``PyconnectError``: the loop's thread would wait for an answer that may need the loop.
"""

# rclpy 7.1 ships py.typed but leaves most functions unannotated.
# mypy: disable-error-code="no-untyped-call,attr-defined"

from __future__ import annotations

import asyncio
import concurrent.futures
import time
from typing import Any

from rclpy.callback_groups import CallbackGroup
from rclpy.task import Future as RosFuture

from pyconnect.errors import PyconnectError
from pyconnect.ros.agent_host import AgentHost
from pyconnect.ros.conversion import DecodeFunc, EncodeFunc
from pyconnect.ros.error_fields import error_message, text_field
from pyconnect.ros.interfaces import interface_class
from pyconnect.ros.node_agent import NodeAgent, ResponseFunc
from pyconnect.ros.option_checks import call_timeout, timeout_problem
from pyconnect.ros.pending_calls import PendingCalls
from pyconnect.ros.qos import REQUESTS
from pyconnect.ros.waiting import Signal, settle, wait_until

SHUTTING_DOWN = "server is shutting down"
"""The answer to requests a server still had waiting when its node shut down."""

REFUSE_FOR_SECONDS = 0.5
"""How long shutdown goes on answering waiting requests: a flood cannot hold it up, nor
requests of clients gone meanwhile (rmw may wait on each such answer)."""


class ServiceServerAgent(NodeAgent):
    """Answers requests on ``conn_name`` with ``response_func``.

    A ``response_func`` that returns None answers the default response (every field at its
    default); where the response type has fields, the first such answer logs a warning.
    """

    conn_type = "service_server"

    def __init__(
        self,
        node: AgentHost,
        *,
        conn_name: str,
        agent_name: str | None = None,
        data_interface: object,
        encode_func: EncodeFunc | None = None,
        decode_func: DecodeFunc | None = None,
        response_func: ResponseFunc | None = None,
        do_log_msg: bool = False,
        callback_group: CallbackGroup | None = None,
    ) -> None:
        srv_class = interface_class(data_interface, kind="srv")
        super().__init__(
            node,
            conn_name=conn_name,
            agent_name=agent_name,
            data_interface=srv_class,
            response_func=response_func,
            do_log_msg=do_log_msg,
            callback_group=callback_group,
        )
        if response_func is None:
            raise self.error("a 'service_server' agent needs a response_func")
        self._handler: ResponseFunc = response_func
        self.request_conversion = self.make_conversion(
            srv_class.Request, decode_func=decode_func, eager=decode_func is None
        )
        self.response_conversion = self.make_conversion(
            srv_class.Response, encode_func=encode_func, eager=encode_func is None
        )
        self.request_count = 0
        self.service = node.ros_node.create_service(
            srv_class,
            conn_name,
            self._on_request,
            qos_profile=REQUESTS,
            callback_group=self.callback_group,
        )
        self.service_name = self.service.service_name

    def _on_request(self, request: Any, response: Any) -> Any:
        self.request_count += 1
        where = "decode"
        try:
            data = self.request_conversion.decode_checked(request)
            self._latest = data
            if self.do_log_msg:
                self.log_msg(data)
            where = "response_func"
            value = self.call_user_and_wait(self._handler, data)
            where = "encode"
            if value is None:
                self.warn_of_default_answer(type(response))
                return response
            msg, _stamped = self.response_conversion.encode(value)
            return msg
        except (SystemExit, KeyboardInterrupt) as error:
            # A handler's sys.exit(): its client is answered with it, then the node shuts
            # down, as for an action goal (pyconnect.ros.action_server_agent); let through, it
            # ended the callback before rclpy sent any response, and the client timed out.
            self.report_exception(where, error)
            self.node.shutdown()  # on a thread of its own, once this callback has ended
            return error_message(type(response), f"{type(error).__name__}: {error}")
        except Exception as error:
            self.report_exception(where, error)
            return error_message(type(response), f"{type(error).__name__}: {error}")

    def close(self) -> None:
        self.refuse_waiting_requests()
        self.node.ros_node.destroy_service(self.service)
        super().close()

    def refuse_waiting_requests(self) -> int:
        """Answer the requests still queued (the executor has stopped) with ``SHUTTING_DOWN``,
        where the response type can say so; returns how many were answered."""
        service = self.service
        if text_field(service.srv_type.Response) is None:
            return 0
        refusal = error_message(service.srv_type.Response, SHUTTING_DOWN)
        answered = 0
        deadline = time.monotonic() + REFUSE_FOR_SECONDS
        while time.monotonic() < deadline:
            with service.handle:
                request, header = service.handle.service_take_request(service.srv_type.Request)
            if request is None or header is None:
                break
            service.send_response(refusal, header)
            answered += 1
        return answered


class ServiceClientAgent(NodeAgent):
    """Calls the service ``conn_name``; ``send``/``get`` return the decoded response."""

    conn_type = "service_client"

    def __init__(
        self,
        node: AgentHost,
        *,
        conn_name: str,
        agent_name: str | None = None,
        data_interface: object,
        encode_func: EncodeFunc | None = None,
        decode_func: DecodeFunc | None = None,
        do_log_msg: bool = False,
        timeout: float | None = None,
        callback_group: CallbackGroup | None = None,
    ) -> None:
        srv_class = interface_class(data_interface, kind="srv")
        super().__init__(
            node,
            conn_name=conn_name,
            agent_name=agent_name,
            data_interface=srv_class,
            do_log_msg=do_log_msg,
            callback_group=callback_group,
        )
        problem = timeout_problem(timeout)
        if problem is not None:
            raise self.error(problem)
        self.timeout = timeout
        self.request_conversion = self.make_conversion(
            srv_class.Request, encode_func=encode_func, eager=encode_func is None
        )
        self.response_conversion = self.make_conversion(
            srv_class.Response, decode_func=decode_func, eager=decode_func is None
        )
        self.client = node.ros_node.create_client(
            srv_class, conn_name, qos_profile=REQUESTS, callback_group=self.callback_group
        )
        self.service_name = self.client.service_name
        self._server_seen = False
        self._pending = PendingCalls(
            node,
            agent_name=self.name,
            during="call",
            server_ready=self.client.service_is_ready,
            failed=self._failed,
        )

    def is_connected(self) -> bool:
        ready: bool = self.client.service_is_ready()
        return ready

    def get(self, data: Any = None, show_info: bool = False) -> Any:  # type: ignore[override]
        """``get(data)`` is ``send(data)``: a service's latest value is the answer to a request."""
        if show_info:
            self.node.get_logger().info(self.info_text())
        return self.send(data)

    def send(self, data: Any = None, *, timeout: float | None = None, block: bool = True) -> Any:
        """Call the service with ``data``; the decoded response, or a future of it."""
        timeout = call_timeout(timeout, self.timeout, where=f"{self.describe}: send")
        if not isinstance(block, bool):  # block="no" blocked
            raise PyconnectError(
                f"{self.describe}: send: block: expected bool, got {type(block).__name__} {block!r}"
            )
        if block:
            self.refuse_to_block_on_loop("send()")
        request, _stamped = self.request_conversion.encode(data)
        if self.do_log_msg:
            self.log_msg(data)
        if not block:
            result: concurrent.futures.Future[Any] = concurrent.futures.Future()
            self._pending.start(
                result,
                lambda future: self._call(request, future),
                timeout=timeout,
                missing=f"no server for {self.service_name}",
                late=f"no response from {self.service_name} within {timeout} s",
            )
            return result
        try:
            return self._call_and_wait(request, timeout)
        except Exception:
            if not self.node.shutdown_event.is_set():
                raise
            # The node was destroyed under the call (a user thread racing shutdown).
            return self._failed(f"node {self.node.qualified_name!r} shut down during the call")

    def _call_and_wait(self, request: Any, timeout: float | None) -> Any:
        if self.node.shutdown_event.is_set():
            return self._failed(f"node {self.node.qualified_name!r} is shut down")
        # Asking the graph costs about as much as a round trip; once the server was seen, a lost
        # server shows up as a timeout, which makes the next call ask again.
        if not self._server_seen:
            if not wait_until(self.client.service_is_ready, timeout, stop=self.node.shutdown_event):
                return self._failed(
                    self.why_no_answer(f"no server for {self.service_name}", timeout)
                )
            self._server_seen = True
        ros_future = self.client.call_async(request)
        # The reply wakes this thread through one bare lock (waiting.Signal): the hand-off
        # from the spinning thread is most of what a blocking call adds to a round trip.
        done = Signal()
        ros_future.add_done_callback(lambda _future: done.set())
        if not self.node.wait_for(done, timeout, poll=ros_future.done):
            self.client.remove_pending_request(ros_future)
            self._server_seen = False
            return self._failed(
                self.why_no_answer(f"no response from {self.service_name}", timeout)
            )
        return self._value_of(ros_future)

    async def send_async(self, data: Any = None, *, timeout: float | None = None) -> Any:
        """``send(data, timeout=...)`` awaited on the caller's asyncio loop, never blocking it."""
        timeout = call_timeout(timeout, self.timeout, where=f"{self.describe}: send_async")
        future = self.send(data, timeout=timeout, block=False)
        # One timer, the call's own (PendingCalls: for the server, then for the answer): a
        # second one here raced it, and the outcome depended on which fired first.
        return await asyncio.wrap_future(future)

    def _failed(self, text: str) -> Any:
        value = self.reform_response(None, error=f"{self.describe}: {text}")
        self._latest = value
        return value

    def _value_of(self, ros_future: RosFuture) -> Any:
        response = ros_future.result()
        if response is None:
            return self._failed("the call was cancelled")
        try:
            decoded = self.response_conversion.decode_checked(response)
        except Exception as error:  # a failed call like any other: response_func sees it too
            self.report_exception("decode", error)
            reason = str(error).removeprefix(f"{self.describe}: ")  # named once, by _failed
            return self._failed(f"could not decode the response: {reason}")
        value = self.reform_response(decoded)
        self._latest = value
        return value

    def _call(self, request: Any, result: concurrent.futures.Future[Any]) -> None:
        ros_future = self.client.call_async(request)

        def finish(done: RosFuture) -> None:
            settle(result, lambda: self._value_of(done))

        def forget_if_cancelled(_result: concurrent.futures.Future[Any]) -> None:
            # The caller gave up, or the answer is late: rclpy need not keep the request.
            if result.cancelled() or self._pending.is_late(result):
                self.client.remove_pending_request(ros_future)

        ros_future.add_done_callback(finish)
        result.add_done_callback(forget_if_cancelled)

    def close(self) -> None:
        self._pending.fail_all()
        self.node.ros_node.destroy_client(self.client)
        super().close()
