"""CoroutineRunner: stopping pyconnect's own loop, from any thread, including its own."""

from __future__ import annotations

import asyncio
import threading

from pyconnect.ros.coroutines import CoroutineRunner

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
