"""What reading a bag reports: the messages it could not decode, and its one damage line.

A message that cannot be decoded is one topic's problem, not the read's: the first on each
topic is logged at once, all are listed, and one warning sums them up at the end of the read
(``on_error="raise"`` raises instead). A damaged bag gets one line saying what is broken, where,
and how many messages were read of those its metadata (or its MCAP statistics) promised.
"""

from __future__ import annotations

import logging
from collections.abc import Container, Sequence
from pathlib import Path
from typing import Literal

from pyconnect.errors import DecodeError
from pyconnect.record.bag_damage import BagDamage
from pyconnect.record.bag_files import BagFiles
from pyconnect.record.bag_message import DecodeProblem
from pyconnect.record.bag_storage import StorageFile
from pyconnect.record.topic_decoder import one_line

__all__ = ["OnError", "ProblemLog", "damage_line", "promised_count"]

_log = logging.getLogger("pyconnect.record")
OnError = Literal["report", "raise"]


class ProblemLog:
    """The messages one read of ``path`` could not decode (``errors``, in reading order)."""

    def __init__(self, path: Path, on_error: OnError) -> None:
        self.path = path
        self.on_error = on_error
        self.errors: list[DecodeProblem] = []
        self._warned_topics: set[str] = set()

    def add(self, topic: str, index: int, log_time: int, error: Exception) -> None:
        """Message ``index`` of ``topic`` did not decode: list it (log the topic's first), or
        raise ``DecodeError`` when the read was opened with ``on_error="raise"``."""
        reason = one_line(error)
        if self.on_error == "raise":
            raise DecodeError(f"{self.path}: {topic}[{index}]: {reason}") from error
        problem = DecodeProblem(topic, index, log_time, reason)
        self.errors.append(problem)
        if topic not in self._warned_topics:
            self._warned_topics.add(topic)
            _log.warning(
                "%s: %s; the read goes on (a summary follows at its end)", self.path, problem
            )

    def count(self, topic: str) -> int:
        """How many messages of ``topic`` did not decode so far."""
        return sum(1 for problem in self.errors if problem.topic == topic)

    def log_summary(self) -> None:
        """One warning for the whole read, when anything did not decode."""
        if not self.errors:
            return
        by_topic: dict[str, int] = {}
        for problem in self.errors:
            by_topic[problem.topic] = by_topic.get(problem.topic, 0) + 1
        summary = ", ".join(f"{topic}: {count}" for topic, count in sorted(by_topic.items()))
        _log.warning(
            "%s: %d message(s) not decoded (%s); first: %s",
            self.path,
            len(self.errors),
            summary,
            self.errors[0],
        )


def damage_line(path: Path, found: Sequence[BagDamage], read: int, promised: int | None) -> str:
    """One line: the first damage (and how many more), what was read of what was promised."""
    more = f" (and {len(found) - 1} more problem(s))" if len(found) > 1 else ""
    if promised is None:
        told = "the bag does not say how many it held"
    else:
        told = f"the bag's metadata promised {promised}"
    return f"{path}: damaged bag: {found[0]}{more}; {read} message(s) read, {told}"


def promised_count(
    bags: Sequence[tuple[BagFiles, Sequence[StorageFile]]], topics: Container[str]
) -> int | None:
    """How many messages of ``topics`` the metadata (or MCAP statistics) declare; None when
    some file does not say."""
    total = 0
    for located, storages in bags:
        metadata = located.metadata
        if metadata is not None and metadata.topics:
            total += sum(t.message_count for t in metadata.topics if t.name in topics)
            continue
        for storage in storages:
            if getattr(storage, "promised", None) is None:
                return None
            counts = storage.message_counts()  # the file's statistics
            total += sum(counts.get(c.id, 0) for c in storage.connections() if c.topic in topics)
    return total
