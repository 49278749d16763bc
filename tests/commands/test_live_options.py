"""The live commands' options: built without rclpy, equal to what rclpy would give."""

from __future__ import annotations

import argparse

import pytest
from rclpy.qos import QoSPresetProfiles

from pyconnect.cli import main
from pyconnect.commands.common import UsageError
from pyconnect.commands.live_options import QOS_PROFILES, add_qos, add_spin_time, ros_missing


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


@pytest.mark.parametrize(
    "command", [["topic", "list"], ["topic", "info", "/x"], ["service", "list"], ["node", "list"]]
)
@pytest.mark.parametrize("seconds", ["nan", "-5", "-0.5", "inf", "1e400", "1e10", "soon"])
def test_spin_time_is_a_finite_number_of_seconds(
    command: list[str], seconds: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # argparse's float took nan and -5 (answered at once, nothing discovered) and inf (hung).
    assert main([*command, "--spin-time", seconds]) == 2
    assert capsys.readouterr().err.splitlines()[-1] == (
        "pyconnect: error: argument --spin-time: expected a number of seconds from 0 to "
        f"9.22e+09, got {seconds!r}"
    )


@pytest.mark.parametrize(("text", "seconds"), [("0", 0.0), ("0.5", 0.5), ("3", 3.0)])
def test_spin_time_takes_seconds_from_zero(text: str, seconds: float) -> None:
    parser = argparse.ArgumentParser()
    add_spin_time(parser, default=1.5)
    assert parser.parse_args([]).spin_time == 1.5
    assert parser.parse_args(["--spin-time", text]).spin_time == seconds


@pytest.mark.parametrize(
    "command",
    [
        ["topic", "echo", "/x"],
        ["topic", "hz", "/x"],
        ["topic", "bw", "/x"],
        ["topic", "pub", "/x", "std_msgs/msg/String"],
        ["service", "call", "/s", "std_srvs/srv/Trigger"],
        ["action", "send_goal", "/a", "test_msgs/action/Fibonacci", "{order: 1}"],
    ],
)
@pytest.mark.parametrize("seconds", ["nan", "-5", "inf", "soon"])
def test_timeout_is_a_finite_number_of_seconds(
    command: list[str], seconds: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # argparse's float took them: nan and inf waited for ever, -5 gave up at once. (``=``: topic
    # pub has a -1 option, so argparse would take a bare -5 for an option.)
    assert main([*command, f"--timeout={seconds}"]) == 2
    assert capsys.readouterr().err.splitlines()[-1] == (
        "pyconnect: error: argument --timeout: expected a number of seconds from 0 to "
        f"9.22e+09, got {seconds!r}"
    )


@pytest.mark.parametrize(
    ("command", "option"),
    [
        (["topic", "pub", "/x", "std_msgs/msg/String", "--once"], "-w"),
        (["bag", "echo", "nowhere"], "--limit"),
    ],
)
def test_counts_are_whole_numbers_from_zero(
    command: list[str], option: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main([*command, f"{option}=-1"]) == 2
    assert "expected" in capsys.readouterr().err.splitlines()[-1]


def test_the_written_out_policies_are_rclpys_but_unknown() -> None:
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, ReliabilityPolicy

    from pyconnect.commands.live_options import QOS_DURABILITIES, QOS_HISTORIES, QOS_RELIABILITIES

    for written, policy in (
        (QOS_RELIABILITIES, ReliabilityPolicy),
        (QOS_DURABILITIES, DurabilityPolicy),
        (QOS_HISTORIES, HistoryPolicy),
    ):
        assert written == tuple(key for key in policy.short_keys() if key != "unknown")


def _qos_args(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    add_qos(parser)
    return parser.parse_args(list(argv))


def test_qos_options_override_the_profile_as_ros2cli() -> None:
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSPresetProfiles, ReliabilityPolicy

    from pyconnect.commands.live_qos import follows_publishers, requested_qos
    from pyconnect.ros.qos import DEFAULT

    latched = requested_qos(_qos_args("--qos-durability", "transient_local"), DEFAULT)
    assert (latched.reliability, latched.durability, latched.depth) == (
        ReliabilityPolicy.RELIABLE,
        DurabilityPolicy.TRANSIENT_LOCAL,
        10,
    )
    given = _qos_args(
        "--qos-profile", "sensor_data", "--qos-reliability", "reliable", "--qos-depth", "3",
        "--qos-history", "keep_all",
    )  # fmt: skip
    qos = requested_qos(given, DEFAULT)
    assert (qos.reliability, qos.durability, qos.depth, qos.history) == (
        ReliabilityPolicy.RELIABLE,
        DurabilityPolicy.VOLATILE,
        3,
        HistoryPolicy.KEEP_ALL,
    )
    # rclpy's presets are shared: overriding one must leave it as it was.
    assert QoSPresetProfiles.get_from_short_key("sensor_data").depth == 5
    assert requested_qos(_qos_args(), DEFAULT) == DEFAULT
    assert follows_publishers(_qos_args("--qos-depth", "100"))
    assert not follows_publishers(_qos_args("--qos-reliability", "best_effort"))
    assert not follows_publishers(_qos_args("--qos-profile", "default"))


@pytest.mark.parametrize(
    "command",
    [
        ["topic", "echo", "/x"],
        ["topic", "hz", "/x"],
        ["topic", "bw", "/x"],
        ["topic", "pub", "/x", "std_msgs/msg/String"],
    ],
)
def test_qos_options_are_ros2s_choices(
    command: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    assert main([*command, "--qos-durability", "latched"]) == 2
    assert capsys.readouterr().err.splitlines()[-1] == (
        "pyconnect: error: argument --qos-durability: invalid choice: 'latched' (choose from "
        "'system_default', 'transient_local', 'volatile', 'best_available')"
    )
    assert main([*command, "--qos-depth", "0"]) == 2
    assert capsys.readouterr().err.splitlines()[-1] == (
        "pyconnect: error: argument --qos-depth: expected a whole number >= 1, got '0'"
    )
