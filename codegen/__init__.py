"""codecgen: reads ROS interface definitions and writes straight-line codec modules."""

from __future__ import annotations

FORMAT_VERSION = "1"
