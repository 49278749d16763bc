"""The files of a split bag as ``SplitRecorder`` keeps them: the open one and the finished ones.

``SplitFile`` is the bag's last file until it is finished (its recorder, its counts);
``FinishedFiles`` holds the finished files' items of metadata.yaml as YAML text, written once
(rewriting every file's at each split made a split cost more with each file), for every later
rewrite of metadata.yaml to reuse (``write_metadata``'s ``preceding``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from pyconnect.record.bag_metadata import list_item_yaml
from pyconnect.record.mcap_recorder import McapRecorder

__all__ = ["FinishedFiles", "SplitFile"]


@dataclass
class SplitFile:
    """The bag's last file until it is finished: its name, its recorder once it is created,
    and its counts."""

    name: str
    recorder: McapRecorder | None = None
    first_ns: int | None = None
    last_ns: int = 0
    count: int = 0
    topics: dict[str, int] = field(default_factory=dict)  # messages of each topic in the file
    failed: bool = False  # a write to it failed: what it holds is known once it is read back

    def entry(self) -> dict[str, Any]:
        """The file's item of metadata.yaml's ``files``."""
        first = self.first_ns or 0
        return {
            "path": self.name,
            "starting_time": {"nanoseconds_since_epoch": first},
            "duration": {"nanoseconds": max(0, self.last_ns - first)},
            "message_count": self.count,
        }


@dataclass
class FinishedFiles:
    """The finished files as metadata.yaml lists them: each one's items as YAML text, and the
    first and last log times of their messages."""

    paths: list[str] = field(default_factory=list)  # items of relative_file_paths
    entries: list[str] = field(default_factory=list)  # items of files, one per finished file
    span: tuple[int, int] | None = None

    def add(self, file: SplitFile) -> None:
        """List ``file`` as finished; safe to repeat when an interrupt cut it short."""
        path = list_item_yaml("relative_file_paths", file.name)
        entry = list_item_yaml("files", file.entry())
        if file.count:  # the span is a min and a max: the same file again leaves it as it is
            first = file.first_ns or 0
            old = self.span or (first, file.last_ns)
            self.span = (min(old[0], first), max(old[1], file.last_ns))
        self._drop_unfinished()
        self.paths.append(path)
        self.entries.append(entry)  # the file counts as finished from here

    def lists(self) -> dict[str, list[str]]:
        """The items, by the list of metadata.yaml they go in (``write_metadata``'s
        ``preceding``)."""
        self._drop_unfinished()
        return {"relative_file_paths": self.paths, "files": self.entries}

    def _drop_unfinished(self) -> None:
        del self.paths[len(self.entries) :]  # left by an add cut short: its file is not finished
