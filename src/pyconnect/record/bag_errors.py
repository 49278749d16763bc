"""``BagError``: a bag cannot be opened, read or written (bad layout, metadata or storage)."""

from __future__ import annotations

from pyconnect.errors import PyconnectError

__all__ = ["BagError"]


class BagError(PyconnectError):
    """A bag cannot be opened, read or written; ``str()`` is one line naming the bag."""
