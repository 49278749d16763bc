"""ROS 2 agents: ``CustomNode`` and one module per agent kind (DESIGN.md §3)."""
