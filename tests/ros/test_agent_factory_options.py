"""The option checks ``agent_factory`` and the zenoh ``Peer`` share (pyconnect.ros.option_checks)."""

from __future__ import annotations

import subprocess
import sys

from pyconnect.ros import agent_factory, option_checks
from pyconnect.ros.agent_factory import AGENT_CLASS_DICT, options_of, shared_options_for

BLOCK_RCLPY = """
import importlib.abc, sys

class BlockRos(importlib.abc.MetaPathFinder):
    def find_spec(self, fullname, path, target=None):
        if fullname == "rclpy" or fullname.startswith(("rclpy.", "rpyutils")):
            raise ImportError(f"{fullname} is blocked in this process")

sys.meta_path.insert(0, BlockRos())
"""


def test_the_old_import_path_still_gives_the_helpers() -> None:
    assert agent_factory.options_of is option_checks.options_of
    accepted, required = options_of(AGENT_CLASS_DICT["timer"])
    assert {"time_period", "response_func"} <= accepted
    assert "time_period" in required
    shared = {"do_log_msg": True, "time_period": 1.0, "tiemout": 1.0}
    assert shared_options_for("sub", shared) == {"do_log_msg": True, "tiemout": 1.0}


def test_the_checks_import_no_rclpy() -> None:
    code = BLOCK_RCLPY + (
        "import pyconnect.ros.option_checks\n"
        "print(sorted(name for name in sys.modules if name.startswith('rclpy')))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=False
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"
