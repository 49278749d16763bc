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

When writing fails (a full disk), the messages received and not in the bag are counted and
reported in one ``BagError`` naming the bag, the failure its cause; a failure to finish the bag
after it (the disk is still full) is told in the same error, never in its place.
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
        # Callbacks of several threads may write at once; ``+=`` alone could lose a count.
        self._count_lock = threading.Lock()
        self._received = 0
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

    @property
    def received(self) -> int:
        """Messages given to ``write`` (those refused after a failure included)."""
        return self._received

    def write(self, topic: str, data: bytes, *, log_time_ns: int) -> None:
        """Queue one message; raises ``BagError`` once the writer has failed."""
        if self._closed:
            raise BagError(f"{self.recorder.directory}: recording is closed")
        with self._count_lock:
            self._received += 1
        if self._failure is not None:
            self._raise_failure()
        self._queue.put((topic, data, log_time_ns))

    def close(self) -> None:
        """Write every queued message, finish the bag; idempotent. Raises ``BagError`` (once)
        when the writer stopped early or the bag could not be finished."""
        if not self._closed:
            self._closed = True
            self._queue.put(None)
            self._thread.join()
        try:
            self.recorder.close()
        except Exception as error:  # Ctrl-C is no failure of the bag: close() finishes it later
            # Reported even when the writer's failure was: this one is news, the count final.
            self._failure = self._failure or error
            self._raise_failure(finishing=None if self._failure is error else error)
        if self._failure is not None and not self._reported:
            self._raise_failure()

    def _run(self) -> None:
        try:
            while (item := self._queue.get()) is not None:
                topic, data, log_time_ns = item
                self.recorder.write(topic, data, log_time_ns=log_time_ns)
        except BaseException as error:  # kept for the recording's thread to raise
            self._failure = error

    def _raise_failure(self, *, finishing: Exception | None = None) -> None:
        """Raise the writer's failure as ``BagError``; ``finishing``: closing the bag failed
        after it (it is told too, and chained as the context)."""
        self._reported = True
        while True:  # what the writer will never write: its memory freed
            try:
                self._queue.get_nowait()
            except queue.Empty:
                break
        # The bag's counts are those of the messages it holds (a file that could not be
        # finished is recounted): the rest were received and lost, in the queue or on the way.
        lost = self._received - sum(self.recorder.counts.values())
        also = "" if finishing is None else f"; finishing it failed too ({finishing})"
        raise BagError(
            f"{self.recorder.directory}: writing the bag failed ({self._failure}); "
            f"{lost} received message(s) not written{also}"
        ) from self._failure

    def __enter__(self) -> QueuedRecorder:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
