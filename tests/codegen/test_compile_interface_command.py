"""``pyconnect interface list|show``: installed and compiled types, printed like ``ros2 interface``."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from pyconnect.cli import main
from tests.codegen.test_compile import TIMEOUT, bare_environment

POSE = """\
# A representation of pose in free space, composed of position and orientation.

Point position
\tfloat64 x
\tfloat64 y
\tfloat64 z
Quaternion orientation
\tfloat64 x 0
\tfloat64 y 0
\tfloat64 z 0
\tfloat64 w 1
"""


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    status = main(argv)
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def test_show_expands_nested_types(capsys: pytest.CaptureFixture[str]) -> None:
    assert run(["interface", "show", "geometry_msgs/msg/Pose"], capsys) == (0, POSE, "")
    assert run(["interface", "show", "geometry_msgs/Pose"], capsys) == (0, POSE, "")


def test_show_a_service_and_raw(capsys: pytest.CaptureFixture[str]) -> None:
    status, out, _ = run(["interface", "show", "std_srvs/SetBool"], capsys)
    assert status == 0
    assert out.startswith("bool data # e.g. for hardware enabling / disabling\n---\nbool success")
    status, out, _ = run(["interface", "show", "--raw", "sensor_msgs/msg/Imu"], capsys)
    assert status == 0 and "std_msgs/Header header" in out and "\t" not in out


@pytest.mark.parametrize(
    ("name", "error"),
    [
        ("nope_msgs/Thing", "pyconnect: error: nope_msgs/msg/Thing: package 'nope_msgs' is not "
         "installed\n"),
        ("std_msgs/msg/Nope", "pyconnect: error: std_msgs/msg/Nope: no such type (Nope.msg is "
         "not in "),
        ("Pose", "pyconnect: error: 'Pose' is not a type name (pkg/msg/Name, pkg/srv/Name or "
         "pkg/Name)\n"),
    ],
)  # fmt: skip
def test_show_errors_are_one_line(
    name: str, error: str, capsys: pytest.CaptureFixture[str]
) -> None:
    status, out, err = run(["interface", "show", name], capsys)
    assert (status, out) == (2, "")
    assert err.startswith(error) and err.count("\n") == 1


def test_list_groups_types_by_kind(capsys: pytest.CaptureFixture[str]) -> None:
    status, out, _ = run(["interface", "list", "std_srvs", "test_msgs"], capsys)
    assert status == 0
    lines = out.splitlines()
    assert lines[0] == "Messages:" and "    test_msgs/msg/BasicTypes" in lines
    services = lines.index("Services:")
    assert lines[services + 1 : services + 4] == [
        "    std_srvs/srv/Empty", "    std_srvs/srv/SetBool", "    std_srvs/srv/Trigger",
    ]  # fmt: skip
    assert "    test_msgs/action/Fibonacci" in lines[lines.index("Actions:") :]
    status, out, _ = run(["interface", "list", "--packages"], capsys)
    assert status == 0 and any(line.startswith("sensor_msgs  (") for line in out.splitlines())


def test_compiled_packages_are_listed_and_shown(compiled_prefix: Path) -> None:
    """In a bare process whose PYTHONPATH holds the compiled prefix, as a user would run it."""
    script = (
        "from pyconnect.cli import main; "
        "main(['interface', 'list', 'tutorial_interfaces']); "
        "main(['interface', 'show', 'tutorial_interfaces/action/MoveTo'])"
    )
    result = subprocess.run(
        [sys.executable, "-c", script],
        env=bare_environment(compiled_prefix),
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
        check=False,
    )
    assert result.stdout == (
        "Messages:\n    tutorial_interfaces/msg/Num\n    tutorial_interfaces/msg/Sphere\n"
        "Services:\n    tutorial_interfaces/srv/AddThreeInts\n"
        "Actions:\n    tutorial_interfaces/action/MoveTo\n"
        "# Move to a point, reporting the distance left.\n"
        "geometry_msgs/Point target\n\tfloat64 x\n\tfloat64 y\n\tfloat64 z\n"
        "float64 speed 1.0\n---\nbool reached\nstring message\n---\nfloat64 remaining\n"
    ), result.stderr
