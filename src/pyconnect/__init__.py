"""pyconnect: zero-boilerplate ROS 2 agents in Python, built on a codec registry."""

from __future__ import annotations

__version__ = "0.1.0"
