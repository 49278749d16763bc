"""Non-ROS peers over zenoh, on rmw_zenoh's wire: ``from pyconnect.transport import Peer``.

Needs the ``zenoh`` extra (``pip install 'pyconnect-ros[zenoh]'``; ``pyconnect`` on the package
registry is an unrelated project); imports no rclpy. Without the extra, importing the package
raises ``ModuleNotFoundError`` saying so.

``start_router`` (and the ``router`` module) load on first use, not with the package:
``python -m pyconnect.transport.router`` imports this package first, and runpy warns
(``RuntimeWarning: ... found in sys.modules``) when the package has already imported the
module it is about to run as ``__main__``.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

# The extra's packages: a missing one is an install to complete, not a bug in pyconnect.
_ZENOH_EXTRA = ("zenoh", "xxhash")

try:
    from pyconnect.transport.peer import Peer
except ModuleNotFoundError as error:
    if (error.name or "").split(".")[0] not in _ZENOH_EXTRA:
        raise
    raise ModuleNotFoundError(
        f"pyconnect.transport needs the zenoh extra ({error}): pip install 'pyconnect-ros[zenoh]'",
        name=error.name,
    ) from error

if TYPE_CHECKING:
    from pyconnect.transport import router as router
    from pyconnect.transport.router import start_router

__all__ = ["Peer", "start_router"]


def __getattr__(name: str) -> object:
    """``start_router`` and ``router``, imported when first asked for."""
    if name == "router":
        return importlib.import_module("pyconnect.transport.router")
    if name == "start_router":
        function: object = importlib.import_module("pyconnect.transport.router").start_router
        globals()[name] = function  # found directly from now on
        return function
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
