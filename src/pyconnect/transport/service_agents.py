"""A peer's ``service_server`` and ``service_client`` agents, as rmw_zenoh maps services.

rmw_zenoh (``rmw_service_data.cpp``, ``rmw_client_data.cpp``): a server is a zenoh queryable
(``complete=True``) on the service's key expression; a client sends a query to it with the
CDR request as payload and an attachment (sequence number, timestamp, client GID), target
``ALL_COMPLETE``, no consolidation; the server replies on its key with the CDR response and an
attachment that echoes the request's sequence number and client GID (pyconnect.transport.
endpoints: ``Server`` and ``Caller``).

Server: ``response_func(request_value) -> response_value`` (an ``async def`` one is awaited on
the agent's thread). Requests are handled one at a time in arrival order and every one is kept
until it is answered, however many arrive at once (keep-all, as CustomNode's servers); ``depth``
is only the QoS depth the token advertises. A handler or codec that raises still answers: a
response with ``success``/``message`` fields gets ``success=False`` and the error text, any
other the default response; the error is logged with the agent's name.

Client: ``send(data, timeout=None)`` returns the decoded response through ``reform_response``.
Only servers of the client's type and RIHS01 hash count (``is_connected``, ``server_count``):
when the name has servers of other types only, the call fails at once naming both types and
hashes. When no server is in the graph within the timeout, when the server vanishes before it
replies, does not reply in time or replies with an error, when the client's peer shuts down
during the call (``"... peer '<name>' is shut down"``, as for a call made after), or when
anything else goes wrong in the call (a reply that does not decode, zenoh's own errors), it returns
``{'isdone': False, 'error': ...}`` as ``CustomNode``'s clients do. ``block=False`` returns a
``concurrent.futures.Future`` of the same (only a request that does not encode raises, at once);
cancelling it drops the call (its query ends; a late response is not read).
"""

# zenoh's stubs leave undeclare() and close() unannotated.
# mypy: disable-error-code="no-untyped-call"

from __future__ import annotations

import concurrent.futures
import contextlib
import threading
import time
from typing import Any

from pyconnect.ros.option_checks import call_timeout, timeout_problem
from pyconnect.transport.async_handlers import settle
from pyconnect.transport.conversion import DecodeFunc, EncodeFunc
from pyconnect.transport.endpoints import CallCancel, Caller, CallFailed, Request, Server
from pyconnect.transport.interface_types import service_interface
from pyconnect.transport.peer_agent import (
    Peer,
    PeerAgent,
    ResponseFunc,
    reform_response,
)

_TEXT_FIELDS = ("message", "error", "error_message", "error_msg", "error_string", "reason")


class ServiceServerAgent(PeerAgent):
    """Answers requests on ``conn_name`` with ``response_func``.

    A ``response_func`` that returns None answers the default response (every field at its
    default); where the response type has fields, the first such answer logs a warning.
    """

    conn_type = "service_server"

    def __init__(
        self,
        peer: Peer,
        *,
        conn_name: str,
        agent_name: str | None = None,
        data_interface: object,
        encode_func: EncodeFunc | None = None,
        decode_func: DecodeFunc | None = None,
        response_func: ResponseFunc | None = None,
        depth: int = 10,
    ) -> None:
        interface = service_interface(data_interface)
        super().__init__(
            peer,
            conn_name=conn_name,
            agent_name=agent_name,
            type_name=interface.type_name,
            response_func=response_func,
        )
        if response_func is None:
            raise self.error("a 'service_server' agent needs a response_func")
        self._handler: ResponseFunc = response_func
        self.request_conversion = self.wire_conversion(interface.request, decode_func=decode_func)
        self.response_conversion = self.wire_conversion(interface.response, encode_func=encode_func)
        self.request_count = 0
        self._server = Server(
            peer,
            self.topic,
            interface,
            self._on_request,
            depth=depth,
            thread_name=f"srv-{self.name}",
        )
        self.key = self._server.key
        self.token_key = self._server.token_key

    @property
    def waiting_requests(self) -> int:
        """Requests that arrived and wait for ``response_func`` (none is ever dropped)."""
        return self._server.waiting

    def _on_request(self, request: Request) -> None:
        self.request_count += 1
        payload = self._answer(request.payload)
        try:
            request.reply(payload)
        except Exception as error:
            self.report_exception("reply", error)

    def _answer(self, request: bytes) -> bytes:
        where = "decode"
        try:
            if not request:
                raise self.error("the query carries no request payload")
            data = self.request_conversion.decode(request)
            self._latest = data
            where = "response_func"
            value = settle(self._handler(data))
            where = "encode"
            if value is None:
                default = self.response_conversion.codec.from_dict({})
                self.warn_of_default_answer(self.response_conversion.codec)
                return default
            return self.response_conversion.encode(value)
        except Exception as error:
            self.report_exception(where, error)
            return self._error_response(f"{type(error).__name__}: {error}")
        except BaseException as error:  # sys.exit() in response_func: answer, then shut down
            self.exit_requested(where, error)
            if self.cancelled_by_shutdown(error):
                return self._error_response(f"peer {self.peer.name!r} is shutting down")
            return self._error_response(f"{type(error).__name__}: {error}")

    def _error_response(self, text: str) -> bytes:
        codec = self.response_conversion.codec
        fields = codec.to_dict(codec.from_dict({}))
        answer: dict[str, Any] = {}
        if isinstance(fields.get("success"), bool):
            answer["success"] = False
        for name in _TEXT_FIELDS:
            if isinstance(fields.get(name), str):
                answer[name] = text
                break
        return codec.from_dict(answer)

    def close(self) -> None:
        self._server.close()


class ServiceClientAgent(PeerAgent):
    """Calls the service ``conn_name``; ``send``/``get`` return the decoded response."""

    conn_type = "service_client"

    def __init__(
        self,
        peer: Peer,
        *,
        conn_name: str,
        agent_name: str | None = None,
        data_interface: object,
        encode_func: EncodeFunc | None = None,
        decode_func: DecodeFunc | None = None,
        timeout: float | None = None,
    ) -> None:
        interface = service_interface(data_interface)
        super().__init__(
            peer, conn_name=conn_name, agent_name=agent_name, type_name=interface.type_name
        )
        problem = timeout_problem(timeout)
        if problem is not None:
            raise self.error(problem)
        self.timeout = timeout
        self.request_conversion = self.wire_conversion(interface.request, encode_func=encode_func)
        self.response_conversion = self.wire_conversion(interface.response, decode_func=decode_func)
        self._caller = Caller(peer, self.topic, interface)
        self.key = self._caller.key
        self.token_key = self._caller.token_key
        self.gid = self._caller.gid

    @property
    def server_count(self) -> int:
        return self._caller.server_count

    def is_connected(self) -> bool:
        return self.server_count > 0

    def waiting_for(self) -> str:
        return self._caller.type_mismatch() or "no server now"

    def get(self, data: Any = None, show_info: bool = False) -> Any:  # type: ignore[override]
        """``get(data)`` is ``send(data)``, as on a ``CustomNode``."""
        return self.send(data)

    def send(self, data: Any = None, *, timeout: float | None = None, block: bool = True) -> Any:
        """Call the service with ``data``; the decoded response, or a future of it."""
        timeout = call_timeout(timeout, self.timeout, where=f"{self.describe}: send")
        payload = self.request_conversion.encode(data)
        if not block:
            result: concurrent.futures.Future[Any] = concurrent.futures.Future()
            dropped = CallCancel()

            def drop_if_cancelled(future: concurrent.futures.Future[Any]) -> None:
                # The caller gave up, as on a CustomNode: the query ends, its reply is not read.
                if future.cancelled():
                    dropped.cancel()

            def call() -> None:
                # The caller may cancel the future at any moment: it then stays cancelled.
                try:
                    value = self._call(payload, timeout, dropped)
                except BaseException as error:  # KeyboardInterrupt...: raised by result()
                    with contextlib.suppress(concurrent.futures.InvalidStateError):
                        result.set_exception(error)
                    return
                with contextlib.suppress(concurrent.futures.InvalidStateError):
                    result.set_result(value)

            result.add_done_callback(drop_if_cancelled)
            threading.Thread(target=call, name=f"pyconnect-{self.name}-call", daemon=True).start()
            return result
        return self._call(payload, timeout)

    def _call(
        self, payload: bytes, timeout: float | None, dropped: CallCancel | None = None
    ) -> Any:
        """The decoded response, or the failure dict: whatever goes wrong, never an exception."""
        try:
            return self._attempt(payload, timeout, dropped)
        except Exception as error:  # zenoh's own errors, a closing session, a bug
            if not self.peer.ok():  # the session closed under the call: nothing went wrong
                return self._failed(self.why_no_answer(f"no response from {self.topic}", timeout))
            self.report_exception("call", error)
            return self._failed(f"the call failed: {type(error).__name__}: {error}")

    def _attempt(self, payload: bytes, timeout: float | None, dropped: CallCancel | None) -> Any:
        deadline = None if timeout is None else time.monotonic() + timeout

        def can_call() -> bool:
            return (
                self.server_count > 0
                or (dropped is not None and dropped.cancelled)
                or self._caller.type_mismatch() is not None
            )

        if not self.peer.wait_for_graph(can_call, deadline):
            return self._failed(self.why_no_answer(f"no server for {self.topic}", timeout))
        # A server of another type would never see the query: say so rather than wait.
        mismatch = self._caller.type_mismatch()
        if mismatch is not None and not (dropped is not None and dropped.cancelled):
            return self._failed(mismatch)
        try:
            response = self._caller.call(payload, deadline, cancel=dropped)
        except CallFailed as failure:
            if failure.timed_out:
                return self._failed(self.why_no_answer(f"no response from {self.topic}", timeout))
            return self._failed(str(failure))
        try:
            decoded = self.response_conversion.decode(response)
        except Exception as error:  # a malformed reply: a failed call, as any other
            self.report_exception("decode", error)
            reason = str(error).removeprefix(f"{self.describe}: ")  # named once, by _failed
            return self._failed(f"could not decode the response: {reason}")
        value = reform_response(decoded)
        self._latest = value
        return value

    def _failed(self, text: str) -> Any:
        value = reform_response(None, error=f"{self.describe}: {text}")
        self._latest = value
        return value

    def close(self) -> None:
        self._caller.close()
