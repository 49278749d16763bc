"""CoroutineRunner and CoroutineLane: stopping the loop, back-pressure, what handlers raise, and
a user's loop that ends before the node."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Iterator

import pytest

from pyconnect.errors import PyconnectError
from pyconnect.ros import coroutines
from pyconnect.ros.coroutines import LANE_LIMIT, CoroutineExit, CoroutineRunner

from .conftest import EVENT_TIMEOUT


def test_stop_from_a_coroutine_on_its_own_loop_ends_the_loop() -> None:
    runner = CoroutineRunner(name="pyconnect-asyncio-self-stop")
    raised: list[BaseException] = []
    stopped = threading.Event()

    async def stop_here() -> None:
        try:
            runner.stop()  # cannot join its own thread: the loop ends once this returns
        except BaseException as error:
            raised.append(error)
        stopped.set()
        await asyncio.sleep(0)

    runner.submit(stop_here())
    assert stopped.wait(EVENT_TIMEOUT)
    assert raised == []
    thread = runner._thread
    assert thread is not None
    thread.join(EVENT_TIMEOUT)
    assert not thread.is_alive()
    assert runner._own_loop is not None and runner._own_loop.is_closed()


@pytest.fixture
def user_loop() -> Iterator[asyncio.AbstractEventLoop]:
    """An asyncio loop running in a thread of its own, as an app's loop would."""
    loop = asyncio.new_event_loop()
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    yield loop
    if not loop.is_closed():
        loop.call_soon_threadsafe(loop.stop)
        thread.join(EVENT_TIMEOUT)
        loop.close()


def _runner(kind: str, user_loop: asyncio.AbstractEventLoop) -> CoroutineRunner:
    if kind == "own loop":
        return CoroutineRunner(name="pyconnect-asyncio-test")
    return CoroutineRunner(user_loop, name="pyconnect-asyncio-test")


@pytest.mark.parametrize("kind", ["own loop", "user's loop"])
def test_a_lane_takes_more_than_its_limit_from_its_own_loop_thread(
    kind: str, user_loop: asyncio.AbstractEventLoop
) -> None:
    # Back-pressure on the loop's thread would wait for the lane to drain, which only that
    # thread does: the loop would be stuck for good (a burst of send_async timeouts did that).
    runner = _runner(kind, user_loop)
    lane = runner.lane()
    count = LANE_LIMIT + 50
    ran: list[int] = []
    all_ran, submitted = threading.Event(), threading.Event()

    async def handle(number: int) -> None:
        ran.append(number)
        if len(ran) == count:
            all_ran.set()

    async def burst() -> None:
        assert runner.on_loop_thread()
        for number in range(count):
            lane.submit(handle, (number,), on_done=None, on_error=lambda _error: None)
        submitted.set()

    try:
        runner.submit(burst())
        assert submitted.wait(EVENT_TIMEOUT), "the loop's thread blocked in submit"
        assert all_ran.wait(EVENT_TIMEOUT)
        assert ran == list(range(count))
    finally:
        runner.stop()


@pytest.mark.parametrize("raised", [SystemExit(3), KeyboardInterrupt()])
def test_sys_exit_in_a_lane_coroutine_is_handed_on_and_the_lane_goes_on(
    raised: BaseException,
) -> None:
    runner = CoroutineRunner(name="pyconnect-asyncio-exit")
    errors: list[BaseException] = []
    exits: list[BaseException] = []
    lane = runner.lane(on_exit=exits.append)
    after = threading.Event()

    async def leave() -> None:
        await asyncio.sleep(0)
        raise raised

    async def next_call() -> None:
        after.set()

    try:
        lane.submit(leave, (), on_done=None, on_error=errors.append)
        lane.submit(next_call, (), on_done=None, on_error=errors.append)
        assert after.wait(EVENT_TIMEOUT), "the lane (or its loop) died"
        assert errors == [raised]
        assert exits == [raised]
        thread = runner._thread
        assert thread is not None and thread.is_alive()
        # A coroutine waited for from another thread: its waiter gets the exit, not the loop.
        outcome = runner.submit(leave())
        with pytest.raises(CoroutineExit) as caught:
            outcome.result(EVENT_TIMEOUT)
        assert caught.value.error is raised
        assert runner.submit(asyncio.sleep(0, "alive")).result(EVENT_TIMEOUT) == "alive"
    finally:
        runner.stop()


def test_a_closed_user_loop_is_reported_once_and_nothing_is_left_unawaited() -> None:
    loop = asyncio.new_event_loop()
    loop.close()
    runner = CoroutineRunner(loop, name="pyconnect-asyncio-closed")
    errors: list[BaseException] = []
    lane = runner.lane()

    async def handle() -> None:
        raise AssertionError("never runs")

    for _ in range(3):
        lane.submit(handle, (), on_done=None, on_error=errors.append)
    assert [str(error) for error in errors] == [
        "the asyncio loop given to CustomNode(loop=) is closed"
    ]
    coroutine = handle()
    future = runner.submit(coroutine)
    with pytest.raises(PyconnectError) as caught:
        future.result(0)
    assert str(caught.value) == "the asyncio loop given to CustomNode(loop=) is closed"
    assert coroutine.cr_frame is None  # closed: no "never awaited" warning (an error here)


def test_a_stopped_user_loop_is_reported_and_its_coroutines_closed(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A lane's calls wait for a loop that is not running (it may not have started yet) up to
    the lane's limit; beyond it they are dropped and that is said once, instead of holding the
    executor's thread for ever. A waited-for call fails at once (a caller is answered)."""
    monkeypatch.setattr(coroutines, "LANE_LIMIT", 2)
    loop = asyncio.new_event_loop()
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    runner = CoroutineRunner(loop, name="pyconnect-asyncio-stopped")
    errors: list[BaseException] = []
    lane = runner.lane()
    ran = threading.Event()

    async def handle() -> None:
        ran.set()

    try:
        lane.submit(handle, (), on_done=None, on_error=errors.append)
        assert ran.wait(EVENT_TIMEOUT)
        loop.call_soon_threadsafe(loop.stop)
        thread.join(EVENT_TIMEOUT)
        assert not thread.is_alive()
        for _ in range(5):  # two wait for the loop, three are dropped: said once
            lane.submit(handle, (), on_done=None, on_error=errors.append)
        assert [str(error) for error in errors] == [
            "the asyncio loop given to CustomNode(loop=) is not running"
        ]
        coroutine = handle()
        with pytest.raises(PyconnectError) as caught:
            runner.submit(coroutine).result(0)
        assert str(caught.value) == "the asyncio loop given to CustomNode(loop=) is not running"
        assert coroutine.cr_frame is None
    finally:
        runner.stop()
        loop.close()


def test_calls_made_before_the_user_loop_starts_run_once_it_does() -> None:
    """A node made before ``loop.run_forever()``: its first messages wait for the loop."""
    loop = asyncio.new_event_loop()
    runner = CoroutineRunner(loop, name="pyconnect-asyncio-later")
    errors: list[BaseException] = []
    lane = runner.lane()
    ran: list[int] = []
    done = threading.Event()

    async def handle(index: int) -> None:
        ran.append(index)
        if len(ran) == 3:
            done.set()

    for index in range(3):
        lane.submit(handle, (index,), on_done=None, on_error=errors.append)
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    try:
        assert done.wait(EVENT_TIMEOUT)
        assert (ran, errors) == ([0, 1, 2], [])
    finally:
        runner.stop()
        loop.call_soon_threadsafe(loop.stop)
        thread.join(EVENT_TIMEOUT)
        loop.close()
