"""``BagDamage``: one place where a bag file is damaged, found while opening or reading it.

Storage readers never raise on a damaged file: they note what they found (``DamageLog``), go on
with the next intact part, and the bag reader reports the list once per read.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["BagDamage", "DamageLog"]


@dataclass(frozen=True)
class BagDamage:
    """What is wrong (``what``) in which file, where (byte ``offset``, None: the whole file)."""

    file: str
    offset: int | None
    what: str

    def __str__(self) -> str:
        where = "" if self.offset is None else f" at byte {self.offset}"
        return f"{self.file}{where}: {self.what}"


class DamageLog:
    """The damage of one storage file, each place noted once however often it is read."""

    def __init__(self, file: str) -> None:
        self.file = file
        self.found: list[BagDamage] = []
        self._keys: set[tuple[int | None, str]] = set()

    def note(self, offset: int | None, what: str, *, key: str | None = None) -> None:
        """Note damage at ``offset``; a second note with the same offset and key is ignored."""
        identity = (offset, what if key is None else key)
        if identity in self._keys:
            return
        self._keys.add(identity)
        self.found.append(BagDamage(self.file, offset, what))
