"""``topic echo|info|pub`` on what ros2 accepts: relative names, any value, ``--times 0``, ``now``."""

from __future__ import annotations

import json
import re

import pytest

from pyconnect.cli import main
from tests.commands.processes import WAIT, Lines, spawn


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    status = main(list(argv))
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def test_echo_json_of_a_dataclass_value_and_a_sequence_field(
    peer: Lines, capsys: pytest.CaptureFixture[str]
) -> None:
    status, out, err = _run(
        capsys, "topic", "echo", "/scan", "--once", "--json", "--timeout", str(WAIT)
    )
    assert (status, err) == (0, "")
    assert json.loads(out) == {
        "ranges": [1.0, 2.0, 3.0],
        "intensities": [],
        "angle_min": -1.0,
        "angle_max": 1.0,
        "angle_increment": 1.0,
        "time_increment": 0.0,
        "scan_time": 0.0,
        "range_min": 0.0,
        "range_max": 10.0,
    }
    status, out, err = _run(
        capsys, "topic", "echo", "/joint_states", "--once", "--field", "position", "--json"
    )
    assert (status, out, err) == (0, "[1.0, 2.5]\n", "")


def test_echo_goes_on_past_a_message_it_cannot_decode(peer: Lines) -> None:
    process = spawn("-m", "pyconnect.cli", "topic", "echo", "/bad_image", merge_stderr=True)
    lines = Lines(process)
    try:
        _seen, warning = lines.wait_for("warning")
        fields, _ = lines.wait_for("^---$")
        _seen, good = lines.wait_for(r"^Image\(")
    finally:
        lines.stop()
    assert warning.string == (
        "pyconnect: warning: [/bad_image]: cannot decode a message (printed as its fields): "
        "Image.data: expected at least 4 bytes (step 2 \N{MULTIPLICATION SIGN} height 2), got 2"
    )
    assert fields[-2].endswith("'step': 2, 'data': b'\\x00\\x00'}")
    assert good.string == "Image(shape=(2, 2), dtype=uint8, encoding=mono8, mean=0.000)"
    assert process.returncode == 130


def test_relative_names_are_expanded(peer: Lines, capsys: pytest.CaptureFixture[str]) -> None:
    status, out, _ = _run(capsys, "topic", "echo", "chatter", "--once", "--timeout", str(WAIT))
    assert status == 0
    assert re.fullmatch(r"'hello \d+'\n---\n", out), out
    status, out, _ = _run(capsys, "topic", "info", "chatter", "--spin-time", str(WAIT))
    assert (status, out.splitlines()[0]) == (0, "Type: std_msgs/msg/String")
    status, out, _ = _run(
        capsys, "service", "call", "set_flag", "std_srvs/srv/SetBool", "{data: true}",
        "--timeout", str(WAIT),
    )  # fmt: skip
    assert (status, out.splitlines()[-2]) == (0, "{'success': True, 'message': 'flag is True'}")
    assert _run(capsys, "topic", "info", "bad name") == (
        2,
        "",
        "pyconnect: error: topic name 'bad name' is invalid: topic name must not contain "
        "characters other than alphanumerics, '_', '~', '{', or '}'\n",
    )


def test_pub_times_zero_publishes_until_ctrl_c(peer: Lines) -> None:
    argv = ["topic", "pub", "commands", "std_msgs/msg/String", "forever", "-t", "0", "-r", "20"]
    process = spawn("-m", "pyconnect.cli", *argv)
    lines = Lines(process)
    try:
        lines.wait_for(r"^publishing #3: 'forever'$")
        peer.wait_for("^got forever$")
    finally:
        err = lines.stop()
    assert (process.returncode, err) == (130, "")


def test_pub_times_must_not_be_negative(capsys: pytest.CaptureFixture[str]) -> None:
    assert _run(capsys, "topic", "pub", "/x", "std_msgs/msg/String", "hi", "--times=-1") == (
        2,
        "",
        "pyconnect: error: argument -t/--times: invalid nonnegative_int value: '-1'\n",
    )


def test_pub_stamps_auto_headers_at_each_publish(capsys: pytest.CaptureFixture[str]) -> None:
    value = "{header: auto, pose: {position: {x: 1.0}}}"
    argv = ["topic", "pub", "/stamped", "geometry_msgs/msg/PoseStamped", value, "-r", "20"]
    process = spawn("-m", "pyconnect.cli", *argv)
    lines = Lines(process)
    stamps = []
    try:
        lines.wait_for(r"^publishing #1: ")
        for _ in range(2):
            status, out, _ = _run(
                capsys, "topic", "echo", "/stamped", "--once", "--field", "header", "--json",
                "--timeout", str(WAIT),
            )  # fmt: skip
            header = json.loads(out)
            assert (status, header["frame_id"]) == (0, "")
            stamps.append((header["stamp"]["sec"], header["stamp"]["nanosec"]))
    finally:
        err = lines.stop()
    assert (process.returncode, err) == (130, "")
    assert stamps[0][0] > 1_600_000_000  # the current time, not the zero of a default header
    assert stamps[1] > stamps[0]


def test_pub_takes_a_multi_array_as_a_list(capsys: pytest.CaptureFixture[str]) -> None:
    status, out, err = _run(
        capsys, "topic", "pub", "/array", "std_msgs/msg/Float64MultiArray", "[1.0, 2.0, 3.0]",
        "--once", "-w", "0",
    )  # fmt: skip
    assert (status, err) == (0, "")
    assert out.splitlines()[-1] == "publishing #1: array([1.0, 2.0, 3.0], dtype=float64)"


def test_pub_takes_numbers_with_an_exponent(capsys: pytest.CaptureFixture[str]) -> None:
    status, out, err = _run(
        capsys, "topic", "pub", "/x", "std_msgs/msg/Float64", '{"data": 1e-3}', "--once",
        "-w", "0",
    )  # fmt: skip
    assert (status, out.splitlines()[-1], err) == (0, "publishing #1: 0.001", "")


def test_pub_shows_a_value_it_cannot_decode_by_its_fields(
    capsys: pytest.CaptureFixture[str],
) -> None:
    status, out, err = _run(
        capsys, "topic", "pub", "/compressed", "sensor_msgs/msg/CompressedImage",
        "{format: jpeg, data: [1, 2, 3]}", "--once", "-w", "0",
    )  # fmt: skip
    assert status == 0
    assert out.splitlines()[-1] == (
        "publishing #1: {'header': {'stamp': {'sec': 0, 'nanosec': 0}, 'frame_id': ''}, "
        "'format': 'jpeg', 'data': b'\\x01\\x02\\x03'}"
    )
    assert err == (
        "pyconnect: warning: cannot decode the CompressedImage (shown as its fields): "
        "CompressedImage.data: cannot decode 3 bytes as jpeg\n"
    )
