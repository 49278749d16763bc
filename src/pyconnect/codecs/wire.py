"""CDR wire codecs: bytes <-> natural values without rclpy (filled in by the wire-codec work)."""

from __future__ import annotations
