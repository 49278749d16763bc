"""Logs, recordings and offline bag reading: the same codecs on files as on a live graph.

- ``MessageLogger`` / ``make_log_dirs``: values of agents as JSON/PNG/NPY files, written on a
  background thread (``log_writer``, ``log_dirs``);
- ``McapRecorder``: raw CDR to MCAP with ros2msg schemas and rosbag2 metadata;
- ``open_bag`` / ``bag_info`` / ``export_topic``: read rosbag2 MCAP and sqlite3 bags without ROS;
  ``open_bag(...).to_arrow|to_pandas|to_polars(topic)`` tables (``tables``), ``align`` matches
  topics by timestamp (``align``).

The writers are imported on first use: a script that only reads a bag does not pay for the MCAP
writer, the log writer's image codecs or the exporters (about 0.2 s of a fresh process). The
reader and ``align`` are imported here because two of their names are also submodules
(``bag_info``, ``align``): importing such a submodule later would otherwise leave the module, not
the function, under the package's name.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from pyconnect.record.align import align, align_table
from pyconnect.record.bag_errors import BagError
from pyconnect.record.bag_reader import (
    BagInfo,
    BagMessage,
    BagReader,
    DecodeProblem,
    TopicInfo,
    bag_info,
    open_bag,
)

if TYPE_CHECKING:
    from pyconnect.record.bag_export import ExportResult, export_topic
    from pyconnect.record.log_dirs import DEFAULT_LOG_ROOT, make_log_dirs, safe_path_component
    from pyconnect.record.log_writer import MessageLogger
    from pyconnect.record.mcap_recorder import McapRecorder

# public name -> the module that defines it (the lazy ones resolve through `__getattr__`)
_HOMES = {
    "DEFAULT_LOG_ROOT": "log_dirs",
    "BagError": "bag_errors",
    "BagInfo": "bag_reader",
    "BagMessage": "bag_reader",
    "BagReader": "bag_reader",
    "DecodeProblem": "bag_reader",
    "ExportResult": "bag_export",
    "McapRecorder": "mcap_recorder",
    "MessageLogger": "log_writer",
    "TopicInfo": "bag_reader",
    "align": "align",
    "align_table": "align",
    "bag_info": "bag_reader",
    "export_topic": "bag_export",
    "make_log_dirs": "log_dirs",
    "open_bag": "bag_reader",
    "safe_path_component": "log_dirs",
}

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
    "align_table",
    "bag_info",
    "export_topic",
    "make_log_dirs",
    "open_bag",
    "safe_path_component",
]


def __getattr__(name: str) -> Any:
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module 'pyconnect.record' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"pyconnect.record.{home}"), name)
    globals()[name] = value  # later lookups skip this function
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
