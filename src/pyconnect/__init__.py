"""pyconnect: zero-boilerplate ROS 2 agents in Python, built on a codec registry."""

from __future__ import annotations

import logging

# A library never configures logging; this keeps unconfigured programs from printing our records
# through Python's last-resort handler.
logging.getLogger("pyconnect").addHandler(logging.NullHandler())

__version__ = "0.1.0"
