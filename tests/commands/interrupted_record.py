"""``pyconnect bag record`` with Ctrl-C delivered at chosen moments, for the race tests.

Run as ``python -m tests.commands.interrupted_record SPLIT ARGS...``: SIGINT is sent to the
process itself right as the SPLIT-th file of the bag is opened (so the handler runs in the middle
of the split), and again as the bag is being finished (a user pressing Ctrl-C twice).
"""

from __future__ import annotations

import os
import signal
import sys

from pyconnect.cli import main
from pyconnect.record.split_recorder import SplitRecorder


def run(split_at: int, argv: list[str]) -> int:
    opened = 0
    open_next = SplitRecorder._open_next
    close = SplitRecorder.close

    def interrupted_open_next(self: SplitRecorder) -> object:
        nonlocal opened
        opened += 1
        if opened == split_at:
            os.kill(os.getpid(), signal.SIGINT)  # its handler runs at the next bytecode
        return open_next(self)

    def interrupted_close(self: SplitRecorder) -> None:
        if not self._closed:
            os.kill(os.getpid(), signal.SIGINT)
        close(self)

    SplitRecorder._open_next = interrupted_open_next  # type: ignore[method-assign,assignment]
    SplitRecorder.close = interrupted_close  # type: ignore[method-assign]
    return main(argv)


if __name__ == "__main__":
    sys.exit(run(int(sys.argv[1]), sys.argv[2:]))
