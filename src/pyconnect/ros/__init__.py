"""ROS 2 agents: ``CustomNode`` and one module per agent kind (docs/design.md §3)."""

# Before any node exists: Fast DDS reads its profile when the process's first node is created.
from pyconnect.ros.large_messages import configure as _configure_large_messages

_configure_large_messages()
