"""A handler's ``sys.exit()`` on a peer: reported, answered where a caller waits, and the peer
shuts down so ``spin()`` returns — as on a ``CustomNode`` (tests/ros/test_executor.py)."""

from __future__ import annotations

import asyncio
import contextlib
import sys
import threading
from typing import Any

import pytest

from pyconnect.errors import PyconnectError
from tests.transport.conftest import TIMEOUT, PeerFactory, wait_for


def _exit(*_args: Any) -> None:
    sys.exit("the mission is over")


def _spin_returns(peer: Any) -> bool:
    """``spin()`` returns (or, the shutdown already done, says the peer is shut down)."""

    def spin() -> None:
        with contextlib.suppress(PyconnectError):
            peer.spin()

    spinner = threading.Thread(target=spin, daemon=True)
    spinner.start()
    spinner.join(TIMEOUT)
    return not spinner.is_alive()


def test_exit_in_a_sub_shuts_the_peer_down(make_peer: PeerFactory) -> None:
    """The agent's thread ended without a word; later samples were never handled and
    ``spin()`` never returned."""
    peer = make_peer("listener")
    sub = peer.add_agent(
        conn_name="chatter", conn_type="sub", data_interface="std_msgs/msg/String",
        response_func=_exit,
    )  # fmt: skip
    pub = peer.add_agent(
        conn_name="chatter", agent_name="out", conn_type="pub",
        data_interface="std_msgs/msg/String",
    )  # fmt: skip

    def send_until_stopped() -> bool:
        with contextlib.suppress(PyconnectError):  # the shutdown began between check and send
            if peer.ok():
                pub.send("stop")
        return not peer.ok()

    assert wait_for(send_until_stopped)
    assert _spin_returns(peer)
    assert sub.last_error == (
        "agent 'chatter' (sub std_msgs/msg/String): receive raised SystemExit: the mission is over"
    )


def test_exit_in_a_service_handler_answers_and_shuts_the_peer_down(
    make_peer: PeerFactory,
) -> None:
    server_peer = make_peer("server")
    server_peer.add_agent(
        conn_name="enable", conn_type="service_server", data_interface="std_srvs/srv/SetBool",
        response_func=_exit,
    )  # fmt: skip
    client_peer = make_peer("client")
    client = client_peer.add_agent(
        conn_name="enable", conn_type="service_client", data_interface="std_srvs/srv/SetBool",
        timeout=TIMEOUT,
    )  # fmt: skip
    client_peer.wait_until_connected(TIMEOUT)
    answer = client.send({"data": True})
    assert answer["success"] is False
    assert answer["message"] == "SystemExit: the mission is over"
    assert _spin_returns(server_peer)


def test_exit_in_an_action_handler_aborts_the_goal_and_shuts_the_peer_down(
    make_peer: PeerFactory,
) -> None:
    """The goal's thread ended: the client waited its whole timeout for a result."""
    server_peer = make_peer("server")
    server_peer.add_agent(
        conn_name="fib", conn_type="action_server", data_interface="test_msgs/action/Fibonacci",
        response_func=_exit,
    )  # fmt: skip
    client_peer = make_peer("client")
    client = client_peer.add_agent(
        conn_name="fib", conn_type="action_client", data_interface="test_msgs/action/Fibonacci",
        timeout=TIMEOUT,
    )  # fmt: skip
    client_peer.wait_until_connected(TIMEOUT)
    result = client.send({"order": 3})
    assert result["isdone"] is False
    assert result["error"].endswith("goal aborted by the server: SystemExit: the mission is over")
    assert _spin_returns(server_peer)


@pytest.mark.parametrize("exiting", [SystemExit("done"), KeyboardInterrupt("stop")])
def test_exit_in_a_timer_shuts_the_peer_down(
    make_peer: PeerFactory, exiting: BaseException
) -> None:
    peer = make_peer("ticker")

    def tick() -> None:
        raise exiting

    timer = peer.add_agent(
        conn_name="tick", conn_type="timer", time_period=0.01, response_func=tick
    )
    assert _spin_returns(peer)
    assert timer.last_error is not None
    assert type(exiting).__name__ in timer.last_error


def test_a_cancelled_error_in_a_handler_is_reported_without_a_shutdown(
    make_peer: PeerFactory,
) -> None:
    """Only an exit request shuts the peer down: an ``asyncio.CancelledError`` (a
    ``BaseException`` too) escaping an ``async def`` handler is reported, the peer goes on."""
    peer = make_peer("ticker")

    async def tick() -> None:
        raise asyncio.CancelledError("an awaited task was cancelled")

    timer = peer.add_agent(
        conn_name="tick", conn_type="timer", time_period=0.01, response_func=tick
    )
    assert wait_for(lambda: timer.error_count >= 2)
    assert peer.ok()
    assert "CancelledError" in (timer.last_error or "")


def test_exit_in_a_polled_pubs_handler_shuts_the_peer_down(make_peer: PeerFactory) -> None:
    """A pub with time_period: its thread ended without a word and spin() never returned."""
    peer = make_peer("poller")
    pub = peer.add_agent(
        conn_name="status", conn_type="pub", data_interface="std_msgs/msg/String",
        time_period=0.01, response_func=_exit,
    )  # fmt: skip
    assert _spin_returns(peer)
    assert pub.last_error == (
        "agent 'status' (pub std_msgs/msg/String): periodic send raised SystemExit: "
        "the mission is over"
    )


def test_exit_in_an_action_clients_response_func_answers_the_future_and_shuts_down(
    make_peer: PeerFactory,
) -> None:
    """block=False: the goal's thread ended, and the caller waited on its future for ever."""
    server_peer = make_peer("server")
    server_peer.add_agent(
        conn_name="fib", conn_type="action_server", data_interface="test_msgs/action/Fibonacci",
        response_func=lambda goal: {"sequence": [1]},
    )  # fmt: skip
    client_peer = make_peer("client")
    client = client_peer.add_agent(
        conn_name="fib", conn_type="action_client", data_interface="test_msgs/action/Fibonacci",
        timeout=TIMEOUT, response_func=_exit,
    )  # fmt: skip
    client_peer.wait_until_connected(TIMEOUT)
    future = client.send({"order": 1}, block=False)
    with pytest.raises(PyconnectError, match="a handler raised SystemExit"):
        future.result(TIMEOUT)
    assert _spin_returns(client_peer)
