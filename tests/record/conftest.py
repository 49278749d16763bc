"""Record tests: import lark (via rosidl) once with its ``sre_parse`` DeprecationWarning muted.

rclpy's type-support import pulls in rosidl_parser -> lark, whose ``import sre_parse`` warns on
Python 3.11+; with ``filterwarnings = error`` that would fail the first test that serialises a
message. The warning is about a third-party import, not about our code.
"""

from __future__ import annotations

import contextlib
import warnings

# A sourced ROS install may not have lark at all: then there is nothing to mute.
with warnings.catch_warnings(), contextlib.suppress(ImportError):
    warnings.filterwarnings("ignore", message="module 'sre_.*' is deprecated")
    import lark  # noqa: F401
