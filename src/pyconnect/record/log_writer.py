"""``MessageLogger``: write logged values to files on a background thread, never blocking callers.

One daemon thread per process serves every logger. Each logger has a bounded number of pending
values; ``log()`` returns False and counts a drop when that bound is reached, so a slow disk
never stalls a ROS callback and nothing is lost silently. Files appear atomically: bytes go to a
hidden temporary file in the same directory, then ``os.replace`` gives it its final name.

File formats (the extension says which; pyconnect.record.log_values encodes them):

- dict, list, tuple, str, int, float, bool, None, numpy scalars and ROS messages -> ``.json``
  (tuples become lists, nested arrays become lists, nested bytes become base64 strings,
  NaN and infinities become the strings ``"nan"``, ``"inf"``, ``"-inf"``: strict JSON has no
  such numbers, and ``bag echo --json`` writes them the same way);
- ``uint8``/``uint16`` arrays (either byte order) of shape (H, W), (H, W, 1), (H, W, 3) or
  (H, W, 4) -> ``.png``
  (channels in OpenCV's BGR(A) order, as ``cv2.imwrite`` takes them; ``log(..., rgb=True)``,
  which agents pass for ``rgb8``/``rgba8`` images, reorders RGB(A) first);
- every other ndarray, structured arrays included -> ``.npy``;
- top-level bytes, bytearray or memoryview -> ``.bin`` (the raw bytes).

Names are ``<sequence:08d>_<stamp_ns>.<ext>``: the sequence keeps the logging order, the stamp is
the ``stamp_ns`` argument, else a ``Stamped`` value's stamp, else the time of ``log()``. A
``Stamped`` value's ``frame_id`` is not written. Values are encoded on the writer thread, so do
not mutate a value after logging it.

A value that cannot be written is counted in ``failed``; the first failure of each kind is
reported (logged, or given to ``on_error``: an agent keeps it as its error), the rest are only
counted, so a folder that vanished under a 200 Hz topic is one report, not 200 lines a second.
A log folder that was removed (someone cleaning old logs) is made again, once each time it is
found gone; when that fails, values fail until the folder is back. Values still queued when
``close(timeout)`` (or the flush at exit) gives up are not written: said, and counted as dropped.
"""

from __future__ import annotations

import atexit
import logging
import os
import queue
import threading
import time
import weakref
from collections.abc import Callable
from pathlib import Path

import numpy as np

from pyconnect.codecs.stamped import Stamped
from pyconnect.errors import PyconnectError
from pyconnect.record.log_values import (
    RgbImage,
    atomic_write_bytes,
    encode_log_value,
    finite_for_json,
    in_native_byte_order,
)

__all__ = [
    "FileWriter",
    "LogWriteError",
    "MessageLogger",
    "atomic_write_bytes",
    "encode_log_value",
    "finite_for_json",
    "in_native_byte_order",
]

_log = logging.getLogger("pyconnect.record")

FileWriter = Callable[[Path, bytes], None]
ErrorHandler = Callable[["LogWriteError"], None]
_EXIT_GRACE_S = 2.0
"""At exit, after the flush gave up: how long the value being written may take to finish."""


class LogWriteError(PyconnectError):
    """A logged value was not written (its ``__cause__`` says why): what ``on_error`` gets."""


class _FolderGone(OSError):
    """The log folder was removed and could not be made again."""


def _failure_kind(error: BaseException) -> tuple[str, object]:
    if isinstance(error, _FolderGone):
        return "_FolderGone", None  # whether making it again failed now or before
    # An OSError's text names the file of each value: its errno says what went wrong.
    if isinstance(error, OSError) and error.errno is not None:
        return type(error).__name__, error.errno
    return type(error).__name__, str(error)


class _WriterThread:
    """The process-wide thread that encodes and writes queued values, in logging order."""

    def __init__(self) -> None:
        self._jobs: queue.SimpleQueue[tuple[MessageLogger, int, int, object]] = queue.SimpleQueue()
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self._pid = os.getpid()

    def submit(self, logger: MessageLogger, sequence: int, stamp_ns: int, value: object) -> None:
        self._ensure_running()
        self._jobs.put((logger, sequence, stamp_ns, value))

    def _ensure_running(self) -> None:
        thread = self._thread
        if thread is not None and thread.is_alive() and self._pid == os.getpid():
            return
        with self._lock:
            if self._pid != os.getpid():  # after fork: the parent's queue and thread are gone
                self._jobs = queue.SimpleQueue()
                self._pid = os.getpid()
                self._thread = None
            if self._thread is None or not self._thread.is_alive():
                self._thread = threading.Thread(
                    target=self._run, name="pyconnect-log-writer", daemon=True
                )
                self._thread.start()

    def _run(self) -> None:
        while True:
            logger, sequence, stamp_ns, value = self._jobs.get()
            logger._write(sequence, stamp_ns, value)


_writer = _WriterThread()
_open_loggers: weakref.WeakSet[MessageLogger] = weakref.WeakSet()


class MessageLogger:
    """Log values of one agent (or topic) as files in ``directory``.

    ``log()`` never blocks: it queues the value and returns True, or returns False and counts a
    drop when ``queue_size`` values are already waiting (or the logger is closed). ``flush()``
    waits until everything queued is on disk; ``close()`` flushes, reports drops and stops.
    ``write_file`` replaces the atomic file writer (tests inject a slow one). ``on_error`` gets
    the first failure of each kind, on the writer thread, instead of the error log.
    """

    def __init__(
        self,
        directory: str | Path,
        *,
        queue_size: int = 256,
        write_file: FileWriter = atomic_write_bytes,
        on_error: ErrorHandler | None = None,
    ) -> None:
        if queue_size < 1:
            raise ValueError(f"queue_size: expected an int >= 1, got {queue_size!r}")
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.queue_size = queue_size
        self._write_file = write_file
        self._on_error = on_error
        self._condition = threading.Condition()
        self._pending = 0
        self._sequence = 0
        self._dropped = 0
        self._written = 0
        self._failed = 0
        self._closed = False
        self._drop_reported = False
        self._reported_kinds: set[tuple[str, object]] = set()  # writer thread only
        self._folder_lost = False  # made again once, in vain: values fail until it is back
        # Set when close() gave up: the writer skips what is left (counted as dropped then).
        self._abandoned = False
        self._writing = False  # the writer holds one of this logger's values
        self._in_flight_dropped = False  # that value is counted as dropped (the program exits)
        _open_loggers.add(self)

    @property
    def dropped(self) -> int:
        """Values refused because the queue was full or the logger closed, or left unwritten
        when ``close()`` gave up waiting."""
        return self._dropped

    @property
    def written(self) -> int:
        """Files written."""
        return self._written

    @property
    def failed(self) -> int:
        """Values that could not be encoded or written (the first of each kind is reported)."""
        return self._failed

    @property
    def pending(self) -> int:
        """Values queued and not yet written."""
        return self._pending

    def log(self, value: object, *, stamp_ns: int | None = None, rgb: bool = False) -> bool:
        """Queue ``value`` for writing; False (and one more drop) when it cannot be queued.

        ``rgb=True`` says an image array holds RGB(A) channels (an ``rgb8`` Image): the writer
        thread reorders them, since PNG files are written from OpenCV's BGR(A) order.
        """
        if stamp_ns is None:
            stamp_ns = value.stamp_ns if isinstance(value, Stamped) else time.time_ns()
        if rgb:
            pixels = value.value if isinstance(value, Stamped) else value
            if isinstance(pixels, np.ndarray):
                value = RgbImage(pixels)
        with self._condition:
            accepted = not self._closed and self._pending < self.queue_size
            if accepted:
                self._pending += 1
                self._sequence += 1
                sequence = self._sequence
            else:
                self._dropped += 1
                first_drop = not self._drop_reported
                self._drop_reported = True
        if accepted:
            _writer.submit(self, sequence, stamp_ns, value)
        elif first_drop:
            reason = "closed" if self._closed else f"queue full ({self.queue_size} pending)"
            _log.warning("%s: dropping logged values: %s", self.directory, reason)
        return accepted

    def flush(self, timeout: float | None = None) -> bool:
        """Wait until every queued value is written (or failed); False if ``timeout`` passed."""
        deadline = None if timeout is None else time.monotonic() + timeout
        with self._condition:
            while self._pending:
                remaining = None if deadline is None else deadline - time.monotonic()
                if remaining is not None and remaining <= 0:
                    return False
                self._condition.wait(remaining)
        return True

    def close(self, timeout: float | None = None) -> None:
        """Stop taking values, write what is queued, and report drops; idempotent.

        When ``timeout`` passes first, the values still queued are not written: a warning says
        how many, and they count as dropped.
        """
        self._close(timeout)

    def _close(self, timeout: float | None, *, exit_limit: float | None = None) -> None:
        """``close(timeout)``; ``exit_limit``: at exit, how long the flush at exit waits for all
        loggers together."""
        with self._condition:
            already = self._closed
            self._closed = True
        if already:
            return
        if not self.flush(timeout):
            assert timeout is not None  # flush() waits for ever without one
            self._abandon(timeout, exit_limit)
        _open_loggers.discard(self)
        if self._dropped or self._failed:
            _log.warning(
                "%s: %d written, %d dropped (queue full or closed), %d failed",
                self.directory,
                self._written,
                self._dropped,
                self._failed,
            )

    def __enter__(self) -> MessageLogger:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return (
            f"MessageLogger({str(self.directory)!r}, written={self._written}, "
            f"dropped={self._dropped}, pending={self._pending})"
        )

    def _abandon(self, timeout: float, exit_limit: float | None) -> None:
        with self._condition:
            self._abandoned = True
            # The value being written still ends as written or failed; the rest are skipped.
            unwritten = self._pending - (1 if self._writing else 0)
            self._dropped += unwritten
        # At exit, the writer must be out of native code (cv2) before the interpreter goes:
        # a daemon thread stopped inside it can abort the process.
        if exit_limit is not None and not self.flush(_EXIT_GRACE_S):
            with self._condition:
                if self._writing:  # the writer ends with the process, this value with it
                    self._in_flight_dropped = True
                    self._dropped += 1
                    unwritten += 1
        if unwritten:
            if exit_limit is None:
                waited = f"close() gave up (timeout {timeout:g} s)"
            else:
                waited = f"the program exited (the logs get {exit_limit:g} s to finish)"
            _log.warning(
                "%s: %d logged value(s) not written: still queued when %s",
                self.directory,
                unwritten,
                waited,
            )

    # -- the writer thread's half -------------------------------------------------------------
    def _write(self, sequence: int, stamp_ns: int, value: object) -> None:
        with self._condition:
            skip = self._abandoned  # counted as dropped by close()
            self._writing = not skip
        try:
            if not skip:
                self._encode_and_write(sequence, stamp_ns, value)
        except Exception as error:  # a bad value or a full disk must not kill the writer
            with self._condition:
                if not self._in_flight_dropped:  # else counted as dropped at exit
                    self._failed += 1
            self._report_failure(sequence, error)
        else:
            with self._condition:
                if not skip and not self._in_flight_dropped:
                    self._written += 1
        finally:
            with self._condition:
                self._writing = False
                self._pending -= 1
                self._condition.notify_all()

    def _encode_and_write(self, sequence: int, stamp_ns: int, value: object) -> None:
        extension, data = encode_log_value(value)
        path = self.directory / f"{sequence:08d}_{stamp_ns}.{extension}"
        try:
            self._write_file(path, data)
        except (FileNotFoundError, NotADirectoryError):  # NotADirectory: a file took its place
            if self.directory.is_dir():
                raise
            self._make_folder_again()
            self._write_file(path, data)

    def _make_folder_again(self) -> None:
        """Make the log folder again after it was removed; ``_FolderGone`` when that fails."""
        if self._folder_lost:
            raise _FolderGone("the log folder was removed and could not be made again") from None
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            # Tried once: every later value would try (and fail) again.
            self._folder_lost = True
            raise _FolderGone(
                f"the log folder was removed and cannot be made again ({error})"
            ) from None
        _log.warning("%s: the log folder was removed; made it again", self.directory)

    def _report_failure(self, sequence: int, error: Exception) -> None:
        kind = _failure_kind(error)
        if kind in self._reported_kinds:
            _log.debug("%s: value %d not written: %s", self.directory, sequence, error)
            return
        self._reported_kinds.add(kind)
        failure = LogWriteError(f"{self.directory}: value {sequence} not written: {error}")
        failure.__cause__ = error
        if self._on_error is None:
            _log.error("%s (further failures like it are only counted)", failure)
            return
        try:
            self._on_error(failure)
        except Exception as callback_error:  # the writer thread serves every logger: go on
            _log.error("%s; on_error raised %r", failure, callback_error)


def _flush_open_loggers_at_exit(timeout: float = 5.0) -> None:
    # Bounded: a slow disk must not hold the exit for ever; what is left is said by close().
    deadline = time.monotonic() + timeout
    for logger in list(_open_loggers):
        logger._close(max(0.0, deadline - time.monotonic()), exit_limit=timeout)


atexit.register(_flush_open_loggers_at_exit)
