"""asyncio loops running in a thread of their own, one with a clock that only the test moves.

With it a test decides when the loop's timers (``asyncio.wait_for``'s, ``call_later``'s) fire
relative to what other threads do, instead of hoping the machine is fast enough.
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
from collections.abc import Iterator
from typing import Any, TypeVar

from .conftest import EVENT_TIMEOUT

LoopT = TypeVar("LoopT", bound=asyncio.AbstractEventLoop)


class ManualClockLoop(asyncio.SelectorEventLoop):
    """``time()`` is ``now``, which only the test changes (on the loop's thread)."""

    def __init__(self) -> None:
        super().__init__()
        self.now = 0.0

    def time(self) -> float:
        return self.now


def manual_clock_loop() -> contextlib.AbstractContextManager[ManualClockLoop]:
    """A running ``ManualClockLoop``, stopped and closed afterwards."""
    return loop_in_a_thread(ManualClockLoop())


@contextlib.contextmanager
def loop_in_a_thread(loop: LoopT) -> Iterator[LoopT]:
    """``loop`` running in a thread of its own (as an app's would), stopped and closed after."""
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    try:
        yield loop
    finally:
        loop.call_soon_threadsafe(loop.stop)
        thread.join(EVENT_TIMEOUT)
        loop.close()


def run_on(loop: asyncio.AbstractEventLoop, coroutine: Any) -> Any:
    """Run ``coroutine`` on ``loop`` (running in another thread) and return its result."""
    return asyncio.run_coroutine_threadsafe(coroutine, loop).result(EVENT_TIMEOUT * 2)
