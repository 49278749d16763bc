"""Logs, recordings and offline bag reading: the same codecs on files as on a live graph.

- ``MessageLogger`` / ``make_log_dirs``: values of agents as JSON/PNG/NPY files, written on a
  background thread (``log_writer``, ``log_dirs``);
- ``McapRecorder``: raw CDR to MCAP with ros2msg schemas and rosbag2 metadata;
- ``open_bag`` / ``bag_info`` / ``export_topic``: read rosbag2 MCAP and sqlite3 bags without ROS;
  ``open_bag(...).to_arrow|to_pandas|to_polars(topic)`` tables (``tables``), ``align`` matches
  topics by timestamp (``align``).
"""

from __future__ import annotations

from pyconnect.record.align import align
from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_export import ExportResult, export_topic
from pyconnect.record.bag_reader import (
    BagInfo,
    BagMessage,
    BagReader,
    DecodeProblem,
    TopicInfo,
    bag_info,
    open_bag,
)
from pyconnect.record.log_dirs import DEFAULT_LOG_ROOT, make_log_dirs, safe_path_component
from pyconnect.record.log_writer import MessageLogger
from pyconnect.record.mcap_recorder import McapRecorder

__all__ = [
    "DEFAULT_LOG_ROOT",
    "BagError",
    "BagInfo",
    "BagMessage",
    "BagReader",
    "DecodeProblem",
    "ExportResult",
    "McapRecorder",
    "MessageLogger",
    "TopicInfo",
    "align",
    "bag_info",
    "export_topic",
    "make_log_dirs",
    "open_bag",
    "safe_path_component",
]
