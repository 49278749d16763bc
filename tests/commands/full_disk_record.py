"""``pyconnect bag record`` on a disk that fills up, for the full-disk test.

Run as ``python -m tests.commands.full_disk_record ROOM ARGS...``: the bag's MCAP files get ROOM
bytes in all (``tests.record.test_split_recorder.full_disk_write``); a write past them writes
what still fits and raises ``OSError(ENOSPC)``, as a full disk does.
"""

from __future__ import annotations

import sys

from pyconnect.cli import main
from pyconnect.record.mcap_recorder import _CountedFile
from tests.record.test_split_recorder import full_disk_write


def run(room: int, argv: list[str]) -> int:
    _CountedFile.write = full_disk_write(room)  # type: ignore[method-assign]
    return main(argv)


if __name__ == "__main__":
    sys.exit(run(int(sys.argv[1]), sys.argv[2:]))
