"""Find the storage files of a bag path: a rosbag2 directory, a bare file, or a split bag.

Opened, their messages are decompressed when rosbag2 compressed them one by one
(``compression_mode: message``; pyconnect.record.message_compression), so that the readers
see CDR; a file compressed whole (``compression_mode: file``, ``bag_0.mcap.zstd``) is read from
a decompressed temporary copy (pyconnect.record.file_compression).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_metadata import METADATA_FILE, BagMetadata, read_metadata
from pyconnect.record.bag_storage import StorageFile
from pyconnect.record.file_compression import (
    FILE_COMPRESSIONS,
    ZSTD_MAGIC,
    compressed_storage_name,
    open_decompressed,
)
from pyconnect.record.message_compression import MAYBE_ZSTD

BagPaths = str | Path | Sequence[str | Path]

__all__ = [
    "STORAGE_SUFFIXES",
    "BagFiles",
    "BagPaths",
    "as_paths",
    "is_storage_file_name",
    "locate_bag_files",
    "open_bag_files",
    "open_storage",
]

_MCAP_MAGIC = b"\x89MCAP0\r\n"
_SQLITE_MAGIC = b"SQLite format 3\x00"
STORAGE_SUFFIXES = (".mcap", ".db3")
_MESSAGE_COMPRESSIONS = ("zstd",)  # what rosbag2 compresses messages one by one with


@dataclass(frozen=True)
class BagFiles:
    """The storage files of a bag, in reading order, and its metadata.yaml when it has one."""

    path: Path
    files: tuple[Path, ...]
    metadata: BagMetadata | None
    message_compression: str = ""
    """The format each message's data is compressed in (metadata.yaml's ``compression_mode:
    message``), "" when stored as it is, ``MAYBE_ZSTD`` without a metadata.yaml to say."""
    missing: tuple[str, ...] = ()
    """The files metadata.yaml lists that are not in the bag, as it lists them: damage (the
    other files are read), not an error that would keep every intact message from the user."""


def is_storage_file_name(path: Path) -> bool:
    """Whether ``path`` is named as a storage file: ``.mcap``, ``.db3``, or either compressed
    whole (``.mcap.zstd``)."""
    return path.suffix in STORAGE_SUFFIXES or compressed_storage_name(path)


def _natural_key(path: Path) -> tuple[object, ...]:
    # multiple_files_10.mcap after multiple_files_9.mcap
    return tuple(int(part) if part.isdigit() else part for part in re.split(r"(\d+)", path.name))


def _listed_file(directory: Path, relative: str) -> Path | None:
    """The file metadata.yaml lists as ``relative``, None when the bag does not hold it."""
    candidate = directory / relative
    if candidate.is_file():
        return candidate
    # rosbag2 before Foxy listed "bagname/bagname_0.db3", relative to the bag's parent.
    by_name = directory / Path(relative).name
    if by_name.is_file():
        return by_name
    return None


def _listed_files(
    directory: Path, listed: Sequence[str]
) -> tuple[tuple[Path, ...], tuple[str, ...]]:
    """(the listed files the bag holds, the listed names it does not); ``BagError`` when it
    holds none of them, as there is then nothing to read."""
    found = [(relative, _listed_file(directory, relative)) for relative in listed]
    files = tuple(path for _relative, path in found if path is not None)
    missing = tuple(relative for relative, path in found if path is None)
    if listed and not files:
        names = ", ".join(repr(relative) for relative in missing)
        which = "which is not" if len(missing) == 1 else "none of which is"
        raise BagError(f"{directory}: metadata.yaml lists {names}, {which} in the bag")
    return files, missing


def _message_compression(path: Path, metadata: BagMetadata) -> str:
    """The format of a bag whose messages are compressed one by one, "" for any other bag."""
    if metadata.compression_mode.lower() != "message":
        return ""
    found = metadata.compression_format.lower()
    if found not in _MESSAGE_COMPRESSIONS:
        expected = " or ".join(repr(name) for name in _MESSAGE_COMPRESSIONS)
        raise BagError(
            f"{path}: compression_format: expected {expected} for compression_mode "
            f"{metadata.compression_mode!r}, got {metadata.compression_format!r}; "
            "decompress the bag with `ros2 bag convert` first"
        )
    return found


def _check_file_compression(path: Path, metadata: BagMetadata) -> None:
    """``BagError`` for files compressed whole in a format that cannot be read."""
    if metadata.compression_mode.lower() != "file":
        return
    if metadata.compression_format.lower() not in FILE_COMPRESSIONS:
        expected = " or ".join(repr(name) for name in FILE_COMPRESSIONS)
        raise BagError(
            f"{path}: compression_format: expected {expected} for compression_mode "
            f"{metadata.compression_mode!r}, got {metadata.compression_format!r}"
        )


def locate_bag_files(path: str | Path) -> BagFiles:
    """Resolve ``path`` to storage files; ``BagError`` when it is not a bag."""
    target = Path(path)
    if target.is_file() and target.name == METADATA_FILE:
        target = target.parent
    if target.is_file():
        return BagFiles(target, (target,), None, MAYBE_ZSTD)
    if not target.is_dir():
        raise BagError(f"{target}: no such bag file or directory")
    metadata_path = target / METADATA_FILE
    if metadata_path.is_file():
        metadata = read_metadata(metadata_path)
        _check_file_compression(metadata_path, metadata)
        files, missing = _listed_files(target, metadata.relative_file_paths)
        compression = _message_compression(metadata_path, metadata)
        return BagFiles(target, files, metadata, compression, missing)
    # No metadata.yaml (a bag before `ros2 bag reindex`): every storage file, in split order.
    found = sorted(
        (p for p in target.iterdir() if is_storage_file_name(p) and p.is_file()),
        key=_natural_key,
    )
    if not found:
        raise BagError(f"{target}: no metadata.yaml and no .mcap or .db3 files")
    return BagFiles(target, tuple(found), None, MAYBE_ZSTD)


def open_storage(path: Path, *, message_compression: str = "") -> StorageFile:
    """Open one storage file, recognised by its first bytes (the suffix may be anything);
    ``message_compression``: the format its messages' data is compressed in ("" none). A file
    compressed whole with zstd is read from a decompressed temporary copy."""
    head = _head(path)
    if head.startswith(ZSTD_MAGIC):
        return open_decompressed(
            path, lambda copy: _open_plain(copy, _head(copy), message_compression)
        )
    return _open_plain(path, head, message_compression)


def _head(path: Path) -> bytes:
    try:
        with path.open("rb") as stream:
            return stream.read(16)
    except OSError as error:
        raise BagError(f"{path}: cannot read ({error.strerror})") from None


def _open_plain(path: Path, head: bytes, message_compression: str) -> StorageFile:
    if head.startswith(_MCAP_MAGIC):
        from pyconnect.record.mcap_storage import McapFile

        return McapFile(path, message_compression=message_compression)
    if head.startswith(_SQLITE_MAGIC):
        from pyconnect.record.sqlite_storage import SqliteFile

        return SqliteFile(path, message_compression=message_compression)
    raise BagError(f"{path}: neither an MCAP nor a sqlite3 bag file")


def as_paths(paths: BagPaths, *, caller: str) -> list[str | Path]:
    """One bag or several, as a list; an empty list raises ``BagError`` naming ``caller``."""
    if isinstance(paths, str | Path):
        return [paths]
    chosen = list(paths)
    if not chosen:
        raise BagError(f"{caller}: no bag given (an empty list)")
    return chosen


def open_bag_files(
    paths: BagPaths, *, into: list[tuple[BagFiles, list[StorageFile]]], caller: str
) -> list[tuple[BagFiles, list[StorageFile]]]:
    """Locate each bag's files and open them, appending to ``into`` as they open (so that the
    caller can close what did open when a later one raises). ``caller`` names the public function
    in errors."""
    for path in as_paths(paths, caller=caller):
        located = locate_bag_files(path)
        storages: list[StorageFile] = []
        into.append((located, storages))
        compression = located.message_compression
        storages.extend(open_storage(p, message_compression=compression) for p in located.files)
    return into
