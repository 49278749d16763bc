"""The error every reader of interface definitions raises: one line naming the file and line."""

from __future__ import annotations

from pathlib import Path

from pyconnect.errors import PyconnectError


class DefinitionError(PyconnectError):
    """A definition cannot be read: ``str()`` is one line naming the file and line."""

    def __init__(self, message: str, *, path: Path | str | None = None, line: int | None = None):
        where = ""
        if path is not None:
            where = f"{path}:{line}: " if line is not None else f"{path}: "
        super().__init__(where + message)
        self.path = path
        self.line = line
