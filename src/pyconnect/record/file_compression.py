"""Storage files compressed whole (rosbag2's ``compression_mode: file``) read from a private copy.

rosbag2 ``--compression-mode file`` compresses each closed storage file with zstd
(``bag_0.mcap.zstd``). The readers need a file they can seek in (MCAP's summary at the end,
sqlite's pages), so each is decompressed, streaming, into a temporary file of its own
(``tempfile``: ``TMPDIR``, else the system's temporary directory; mode 0600), which is removed
when the storage closes, or at once when opening it fails. Bags are GBs: nothing is read whole
into memory, and a full disk is a ``BagError`` that says where the room is missing.
"""

from __future__ import annotations

import dataclasses
import errno
import io
import tempfile
import weakref
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any, BinaryIO

from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_storage import Connection, RawMessage, StorageFile

__all__ = [
    "FILE_COMPRESSIONS",
    "ZSTD_MAGIC",
    "DecompressedStorage",
    "compressed_storage_name",
    "open_decompressed",
]

ZSTD_MAGIC = b"\x28\xb5\x2f\xfd"
FILE_COMPRESSIONS = ("zstd",)  # what rosbag2 compresses whole files with
_STEP = 1 << 20  # bytes read and written at a time: memory stays at a few of these


def compressed_storage_name(path: Path) -> bool:
    """Whether ``path`` is named as rosbag2 names a storage file compressed whole."""
    return path.suffix == ".zstd" and Path(path.stem).suffix in (".mcap", ".db3")


class DecompressedStorage:
    """A storage file opened on its decompressed copy: its ``path`` and damage name the
    compressed file, and ``close()`` also removes the copy. What the storage offers besides
    the protocol (``damage``, ``promised``) is its own, reached through this one."""

    def __init__(self, inner: StorageFile, copy: Path, label: str) -> None:
        self.inner = inner
        self.copy = copy
        self.path = label
        # A reader never closed (``list(open_bag(p))``) must not leave a bag's worth of disk
        # behind: the copy also goes when this is collected, or at the latest when Python exits.
        self._remove = weakref.finalize(self, copy.unlink, missing_ok=True)

    def connections(self) -> Sequence[Connection]:
        return self.inner.connections()

    def message_counts(self) -> dict[int, int]:
        return self.inner.message_counts()

    def time_range(self) -> tuple[int, int] | None:
        return self.inner.time_range()

    def messages(
        self, connection_ids: set[int], start_ns: int | None, end_ns: int | None
    ) -> Iterator[RawMessage]:
        return self.inner.messages(connection_ids, start_ns, end_ns)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.inner, name)

    def close(self) -> None:
        try:
            self.inner.close()
        finally:
            self._remove()


def _write(target: io.FileIO, data: bytes) -> None:
    # Unbuffered, so that a full disk is met here and not when the file closes; a raw write
    # may take part of the data.
    view = memoryview(data)
    while view:
        written = target.write(view)
        if not written:  # a regular file takes some or raises: never loop for ever
            raise OSError(errno.EIO, "the file takes no more data")
        view = view[written:]


def _decompress(path: Path, source: BinaryIO, target: io.FileIO, directory: str) -> str | None:
    """Copy ``source`` (zstd, one frame or several) decompressed into ``target``; why the
    copy ends early (data that do not decompress, or a frame cut short), None when it is whole.

    Frame by frame with ``decompressobj``: zstandard's stream reader ends quietly where a file
    cut short ends, and the copy would pass for the whole bag."""
    import zstandard

    decompressor = zstandard.ZstdDecompressor()
    frame = decompressor.decompressobj()
    in_frame = False  # input given to ``frame`` that has not ended it yet
    written = 0
    while True:
        try:
            chunk = source.read(_STEP)
        except OSError as error:
            raise BagError(f"{path}: cannot read ({error.strerror})") from None
        if not chunk:
            if in_frame:
                return f"the zstd data end early, in a frame, after {written} bytes; not read"
            return None
        while chunk:
            try:
                piece = frame.decompress(chunk)
            except zstandard.ZstdError as error:
                # Damaged data: what came before is intact, and the storage reader reads it.
                return f"the zstd data do not decompress after {written} bytes ({error}); not read"
            _write_or_say(path, target, piece, written, directory)
            written += len(piece)
            if frame.eof:  # the next frame starts in what this one left over
                chunk, frame, in_frame = frame.unused_data, decompressor.decompressobj(), False
            else:
                chunk, in_frame = b"", True


def _write_or_say(
    path: Path, target: io.FileIO, piece: bytes, written: int, directory: str
) -> None:
    """``_write``, its failure a ``BagError`` that says where room is missing."""
    try:
        _write(target, piece)
    except OSError as error:
        if error.errno in (errno.ENOSPC, errno.EDQUOT):
            raise BagError(
                f"{path}: cannot decompress into {directory}: no space left on the device "
                f"after {written} bytes; set TMPDIR to a directory with room for the "
                "decompressed file"
            ) from None
        raise BagError(f"{path}: cannot decompress into {directory} ({error.strerror})") from None


def _decompressed_copy(path: Path) -> tuple[Path, str | None]:
    """A private temporary file holding ``path`` decompressed, and why it ends early (None:
    whole); removed again when that fails."""
    directory = tempfile.gettempdir()
    suffix = Path(path.stem).suffix  # bag_0.mcap.zstd -> .mcap: the copy says what it is
    try:
        handle, name = tempfile.mkstemp(prefix="pyconnect-decompressed-", suffix=suffix)
    except OSError as error:
        raise BagError(f"{path}: cannot decompress into {directory} ({error.strerror})") from None
    copy = Path(name)
    try:
        with io.FileIO(handle, "wb") as target, path.open("rb") as source:
            cut = _decompress(path, source, target, directory)
    except BaseException:
        copy.unlink(missing_ok=True)
        raise
    return copy, cut


def open_decompressed(path: Path, opener: Callable[[Path], StorageFile]) -> StorageFile:
    """``path`` (compressed whole with zstd) opened by ``opener`` from a decompressed copy."""
    try:
        copy, cut = _decompressed_copy(path)
    except OSError as error:  # the compressed file itself
        raise BagError(f"{path}: cannot read ({error.strerror})") from None
    label = f"{path} (decompressed)"  # byte offsets in reports are the decompressed file's
    try:
        inner = opener(copy)
    except BagError as error:
        copy.unlink(missing_ok=True)
        why = str(error).replace(str(copy), label)
        raise BagError(why if cut is None else f"{why}; {cut}") from None
    except BaseException:
        copy.unlink(missing_ok=True)
        raise
    storage = DecompressedStorage(inner, copy, label)
    # The storage names its damage by the file it opened, which is gone when it closes.
    inner.path = label
    log = getattr(inner, "damage", None)
    if log is not None:
        log.file = label
        log.found[:] = [dataclasses.replace(found, file=label) for found in log.found]
        if cut is not None:
            log.note(None, cut)
    elif cut is not None:  # no damage to note it in: an error, not a silent loss
        storage.close()
        raise BagError(f"{label}: {cut}")
    return storage
