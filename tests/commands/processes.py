"""Child processes for the live-tool tests: spawn one, read its stdout lines, stop it with Ctrl-C."""

from __future__ import annotations

import os
import queue
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
WAIT = 90.0  # generous: the machine is shared and loaded


class Lines:
    """A child process's stdout lines, read on a thread."""

    def __init__(self, process: subprocess.Popen[str]) -> None:
        self.process = process
        self.lines: queue.Queue[str] = queue.Queue()
        assert process.stdout is not None
        stream = process.stdout
        self.reader = threading.Thread(target=self._read, args=(stream,), daemon=True)
        self.reader.start()

    def stop(self, signum: int = signal.SIGINT) -> str:
        """Ctrl-C (or ``signum``) the process, wait for it to end and return its stderr."""
        process = self.process
        if process.stdin is not None:
            process.stdin.close()
        process.send_signal(signum)
        process.wait(timeout=WAIT)
        self.reader.join(timeout=WAIT)
        assert process.stdout is not None
        err = ""
        if process.stderr is not None:  # None: merged into stdout, read as lines
            err = process.stderr.read()
            process.stderr.close()
        process.stdout.close()
        return err

    def _read(self, stream: object) -> None:
        for line in stream:  # type: ignore[attr-defined]
            self.lines.put(line.rstrip("\n"))

    def wait_for(self, pattern: str, timeout: float = WAIT) -> tuple[list[str], re.Match[str]]:
        seen: list[str] = []
        deadline = time.monotonic() + timeout
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise AssertionError(f"no line matching {pattern!r}; got {seen!r}")
            try:
                line = self.lines.get(timeout=remaining)
            except queue.Empty:
                continue
            seen.append(line)
            found = re.search(pattern, line)
            if found:
                return seen, found


def spawn(*args: str, merge_stderr: bool = False) -> subprocess.Popen[str]:
    """``python *args``; with ``merge_stderr`` its stderr lines are read among stdout's."""
    return subprocess.Popen(
        [sys.executable, *args],
        cwd=ROOT,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT if merge_stderr else subprocess.PIPE,
        text=True,
        env=dict(os.environ, PYTHONUNBUFFERED="1"),
    )
