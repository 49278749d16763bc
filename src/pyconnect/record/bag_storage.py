"""What the bag reader needs from one storage file (MCAP or sqlite3), whatever its format."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Protocol

__all__ = ["Connection", "RawMessage", "StorageFile"]

RawMessage = tuple[int, int, "bytes | memoryview"]
"""(connection id, log time in ns, CDR bytes) of one stored message."""


@dataclass(frozen=True)
class Connection:
    """A topic as one storage file declares it, with the definition stored for its type.

    ``definition`` is None when the file stores none (pre-Iron sqlite3, an MCAP channel without
    schema, or a definition rosbag2 marked "unknown"): readers then use the installed type.
    """

    id: int
    topic: str
    msg_type: str
    serialization_format: str
    definition: str | None = None
    definition_encoding: str = "ros2msg"
    offered_qos_profiles: str = ""
    type_hash: str = ""  # the RIHS01 hash rosbag2 stores for the type ("" when none)


class StorageFile(Protocol):
    """One opened storage file; ``close()`` releases it."""

    path: str

    def connections(self) -> Sequence[Connection]: ...

    def message_counts(self) -> dict[int, int]:
        """Connection id -> number of messages stored."""
        ...

    def time_range(self) -> tuple[int, int] | None:
        """(first, last) log time in ns, None for a file with no messages."""
        ...

    def messages(
        self, connection_ids: set[int], start_ns: int | None, end_ns: int | None
    ) -> Iterator[RawMessage]:
        """Messages of those connections with ``start_ns <= log time < end_ns``, in time order."""
        ...

    def close(self) -> None: ...
