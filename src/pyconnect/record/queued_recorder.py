"""``QueuedRecorder``: a ``SplitRecorder`` written on a thread of its own, fed by a queue.

``pyconnect bag record`` receives messages in subscription callbacks, and a subscription keeps
only its last few messages: a callback that takes a while (a file split: finish the file, open
the next, rewrite metadata.yaml; a chunk compressed) makes the next messages overwrite each
other before they are taken. ``write`` here only appends to a queue and returns; a writer thread
takes the messages in order and writes them, splits included, as ``ros2 bag record`` writes from
its cache thread. The queue has no bound: a disk slower than the topics costs memory, never a
message (nothing is lost silently). ``close()`` writes what is still queued, then finishes the
bag. Ctrl-C never lands on the writer thread (Python delivers signals to the main thread), so a
write or a split is never cut in the middle.
"""

from __future__ import annotations

import queue
import threading

from pyconnect.record.bag_errors import BagError
from pyconnect.record.split_recorder import SplitRecorder

__all__ = ["QueuedRecorder"]

_Item = tuple[str, bytes, int]  # topic, CDR bytes, log time in ns


class QueuedRecorder:
    """Write ``recorder``'s messages on a writer thread; ``write`` never waits for the disk.

    Topics are added to ``recorder`` directly (``SplitRecorder.add_topic`` is thread-safe),
    before the first message of each is written here.
    """

    def __init__(self, recorder: SplitRecorder) -> None:
        self.recorder = recorder
        self._queue: queue.SimpleQueue[_Item | None] = queue.SimpleQueue()
        self._failure: BaseException | None = None
        self._reported = False
        self._closed = False
        self._thread = threading.Thread(
            target=self._run, name=f"bag writer {recorder.directory.name}", daemon=True
        )
        self._thread.start()

    @property
    def pending(self) -> int:
        """Messages received and not written yet (approximate while the writer runs)."""
        return self._queue.qsize()

    def write(self, topic: str, data: bytes, *, log_time_ns: int) -> None:
        """Queue one message; raises ``BagError`` once the writer has failed."""
        if self._closed:
            raise BagError(f"{self.recorder.directory}: recording is closed")
        if self._failure is not None:
            self._raise_failure()
        self._queue.put((topic, data, log_time_ns))

    def close(self) -> None:
        """Write every queued message, finish the bag; idempotent. Raises the writer's failure
        (once) when it stopped early."""
        if not self._closed:
            self._closed = True
            self._queue.put(None)
            self._thread.join()
        self.recorder.close()
        if self._failure is not None and not self._reported:
            self._raise_failure()

    def _run(self) -> None:
        try:
            while (item := self._queue.get()) is not None:
                topic, data, log_time_ns = item
                self.recorder.write(topic, data, log_time_ns=log_time_ns)
        except BaseException as error:  # kept for the recording's thread to raise
            self._failure = error

    def _raise_failure(self) -> None:
        self._reported = True
        lost = 0
        while True:  # what the writer will never write: counted, and its memory freed
            try:
                lost += self._queue.get_nowait() is not None
            except queue.Empty:
                break
        raise BagError(
            f"{self.recorder.directory}: writing the bag failed ({self._failure}); "
            f"{lost} received message(s) not written"
        ) from self._failure

    def __enter__(self) -> QueuedRecorder:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
