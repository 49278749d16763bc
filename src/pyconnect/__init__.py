"""pyconnect: zero-boilerplate ROS 2 agents in Python, built on a codec registry."""

from __future__ import annotations

# No logging set-up here, not even a NullHandler: until a program configures logging, what
# pyconnect reports (a peer's sample of another type, a callback that raised, a damaged bag) reaches
# stderr through logging's last-resort handler, as the design promises; nothing is lost silently.

__version__ = "0.1.0"
