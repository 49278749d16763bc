"""The live commands' options: built without rclpy, equal to what rclpy would give."""

from __future__ import annotations

from rclpy.qos import QoSPresetProfiles

from pyconnect.commands.common import UsageError
from pyconnect.commands.live_options import QOS_PROFILES, ros_missing


def test_the_written_out_presets_are_rclpys_but_unknown() -> None:
    from_rclpy = tuple(key for key in QoSPresetProfiles.short_keys() if key != "unknown")
    assert from_rclpy == QOS_PROFILES


def test_only_rclpy_missing_is_the_ros_extra_missing() -> None:
    missing = ros_missing(ModuleNotFoundError("No module named 'rclpy'", name="rclpy"))
    assert isinstance(missing, UsageError)
    assert str(missing) == (
        "this command talks to a live ROS 2 graph and needs rclpy (No module named 'rclpy'): "
        "pip install 'pyconnect-ros[ros]', or source a ROS 2 Jazzy install"
    )
    inner = ModuleNotFoundError("No module named 'rclpy.qos'", name="rclpy.qos")
    assert ros_missing(inner) is not None
    # Another module missing is a bug to be shown with its traceback, not an install hint.
    assert ros_missing(ModuleNotFoundError("No module named 'yaml'", name="yaml")) is None
    assert ros_missing(ModuleNotFoundError("No module named 'rclpyx'", name="rclpyx")) is None
    assert ros_missing(ImportError("cannot import name 'x' from 'rclpy'", name="rclpy")) is None
