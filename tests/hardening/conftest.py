"""The ROS fixtures of tests/ros serve the hardening tests too."""

from tests.ros.conftest import make_node

__all__ = ["make_node"]
