"""The error every reader of interface definitions raises: one line naming the file and line."""

from __future__ import annotations

from pathlib import Path

from pyconnect.errors import PyconnectError


class DefinitionError(PyconnectError):
    """A definition cannot be read: ``str()`` is one line naming the file and line.

    ``member`` names the field or constant at fault when the raiser knows it but not the text:
    the reader that holds the text adds the line declaring it (``parse.parse_interface_text``).
    """

    def __init__(
        self,
        message: str,
        *,
        path: Path | str | None = None,
        line: int | None = None,
        member: str | None = None,
    ):
        where = ""
        if path is not None:
            where = f"{path}:{line}: " if line is not None else f"{path}: "
        super().__init__(where + message)
        self.detail = message
        self.path = path
        self.line = line
        self.member = member
