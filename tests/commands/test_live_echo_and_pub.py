"""``topic echo|info|pub`` on what ros2 accepts: relative names, any value, ``--times 0``, ``now``."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time
from collections.abc import Callable, Iterator

import pytest

from pyconnect.cli import main
from tests.commands.processes import WAIT, Lines, spawn


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    status = main(list(argv))
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def _until(
    capsys: pytest.CaptureFixture[str], check: Callable[[int, str], bool], *argv: str
) -> tuple[int, str, str]:
    """Run a command until ``check(status, out)`` passes: what a new process sees of the graph
    depends on how far discovery has got."""
    deadline = time.monotonic() + WAIT
    while True:
        status, out, err = _run(capsys, *argv)
        if check(status, out) or time.monotonic() > deadline:
            return status, out, err


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
    status, out, _ = _until(capsys, lambda status, _out: status == 0, "topic", "info", "chatter")
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
        "pyconnect: error: argument -t/--times: expected a whole number >= 0, got '-1'\n",
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


@pytest.fixture(scope="module")
def qos_peers() -> Iterator[None]:
    """tests/commands/qos_peer: latched, best-effort and action-feedback topics, and /multi
    published as String by one process and as Float64 by another."""
    peers = [Lines(spawn("-m", "tests.commands.qos_peer", mode)) for mode in ("main", "float")]
    try:
        for peer in peers:
            peer.wait_for("^ready$")
        yield
    finally:
        for peer in peers:
            peer.stop()


@pytest.mark.parametrize(
    ("topic", "msg_type", "shown"),
    [
        ("/latched", "std_msgs/msg/String", "'latched hello'"),
        ("/best_effort", "std_msgs/msg/Float64", "1.5"),
    ],
)
def test_echo_with_the_type_given_matches_the_publishers_qos(
    topic: str, msg_type: str, shown: str, qos_peers: None, capsys: pytest.CaptureFixture[str]
) -> None:
    # The QoS was chosen before discovery: reliable and volatile, deaf to both publishers.
    assert _run(capsys, "topic", "echo", topic, msg_type, "--once", "--timeout", str(WAIT)) == (
        0,
        f"{shown}\n---\n",
        "",
    )


def test_echo_and_hz_of_an_action_feedback_topic(
    qos_peers: None, capsys: pytest.CaptureFixture[str]
) -> None:
    topic = "/fib/_action/feedback"
    status, out, err = _run(
        capsys, "topic", "echo", topic, "--once", "--json", "--timeout", str(WAIT)
    )
    assert (status, err) == (0, "")
    assert json.loads(out)["feedback"] == {"sequence": [0, 1, 1]}
    given = ["test_msgs/action/Fibonacci_FeedbackMessage", "--field", "feedback.sequence"]
    assert _run(
        capsys, "topic", "echo", topic, *given, "--once", "--json", "--timeout", str(WAIT)
    ) == (0, "[0, 1, 1]\n", "")
    process = spawn("-m", "pyconnect.cli", "topic", "hz", topic)
    lines = Lines(process)
    try:
        lines.wait_for(r"^average rate: \d+\.\d{3}$")
    finally:
        err = lines.stop()
    assert (process.returncode, err) == (130, "")


def test_a_topic_of_two_types(qos_peers: None, capsys: pytest.CaptureFixture[str]) -> None:
    both = "Type: ['std_msgs/msg/Float64', 'std_msgs/msg/String']"
    argv = ["topic", "info", "/multi", "--spin-time", "5"]  # two processes to discover
    status, out, _ = _until(capsys, lambda _status, out: both in out, *argv)
    assert (status, out.splitlines()) == (
        0,
        [both, "Publisher count: 2", "Subscription count: 0"],
    )
    # echo refusing without the type is test_live_tools' (a new process may find one of the
    # two publishers seconds before the other): given the type, it hears its publisher.
    argv = ["topic", "echo", "/multi", "std_msgs/msg/Float64", "--once", "--timeout", str(WAIT)]
    assert _run(capsys, *argv) == (0, "2.5\n---\n", "")


def test_rcl_refusing_an_endpoint_is_one_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from rclpy.impl.implementation_singleton import rclpy_implementation
    from rclpy.node import Node

    def refuse(kind: str, create: Callable[..., object]) -> Callable[..., object]:
        # Only /nobody: a node makes endpoints of its own (/parameter_events, /rosout).
        def refused(node: Node, msg_type: type, topic: str, *args: object, **kw: object) -> object:
            if topic != "/nobody":
                return create(node, msg_type, topic, *args, **kw)
            raise rclpy_implementation.RCLError(
                f"Failed to create {kind}: invalid allocator, at /project/src/rcl/{kind}.c:261"
            )

        return refused

    monkeypatch.setattr(
        Node, "create_subscription", refuse("subscription", Node.create_subscription)
    )
    monkeypatch.setattr(Node, "create_publisher", refuse("publisher", Node.create_publisher))
    argv = ["/nobody", "std_msgs/msg/String"]
    assert _run(capsys, "topic", "echo", *argv, "--timeout", "0") == (
        1,
        "",
        "pyconnect: error: cannot subscribe to /nobody: Failed to create subscription: "
        "invalid allocator\n",
    )
    assert _run(capsys, "topic", "pub", *argv, "hi", "--once", "-w", "0") == (
        1,
        "",
        "pyconnect: error: cannot publish on /nobody: Failed to create publisher: "
        "invalid allocator\n",
    )


def test_echo_hears_a_best_effort_publisher_that_comes_after_it_subscribed() -> None:
    # echo subscribed reliably, as its only publisher then offered; a best-effort publisher
    # found later went unheard (its QoS was chosen once, from the first publisher).
    reliable = Lines(spawn("-m", "tests.commands.mix_peer", "reliable"))
    late: Lines | None = None
    echo = Lines(spawn("-m", "pyconnect.cli", "topic", "echo", "/mix", "std_msgs/msg/String"))
    try:
        reliable.wait_for("^ready$")
        echo.wait_for("^'reliable'$")
        late = Lines(spawn("-m", "tests.commands.mix_peer", "best_effort"))
        late.wait_for("^ready$")
        echo.wait_for("^'best_effort'$")
    finally:
        err = echo.stop()
        for peer in (reliable, late):
            if peer is not None:
                peer.stop()
    assert echo.process.returncode == 130
    assert err == (
        "pyconnect: note: [/mix]: a publisher it could not hear appeared: subscribed again "
        "best_effort, volatile (was reliable, volatile)\n"
    )


def test_pub_latched_with_qos_durability(capsys: pytest.CaptureFixture[str]) -> None:
    # One message, then nothing for 1000 s: only a transient-local publisher hands it to a
    # subscriber that comes later.
    argv = ["topic", "pub", "/latched_by_cli", "std_msgs/msg/String", "kept", "-r", "0.001"]
    process = spawn("-m", "pyconnect.cli", *argv, "--qos-durability", "transient_local")
    lines = Lines(process)
    try:
        lines.wait_for(r"^publishing #1: 'kept'$")
        assert _run(
            capsys, "topic", "echo", "/latched_by_cli", "--once", "--timeout", str(WAIT)
        ) == (0, "'kept'\n---\n", "")
    finally:
        err = lines.stop()
    assert (process.returncode, err) == (130, "")


def test_echo_no_arr_shows_arrays_by_type_and_length(
    peer: Lines, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["topic", "echo", "/joint_states", "--once", "--no-arr", "--timeout", str(WAIT)]
    assert _run(capsys, *argv) == (
        0,
        "{'header': {'stamp': {'sec': 0, 'nanosec': 0}, 'frame_id': ''}, "
        "'name': <sequence type: string, length: 2>, "
        "'position': <sequence type: double, length: 2>, "
        "'velocity': <sequence type: double, length: 0>, "
        "'effort': <sequence type: double, length: 0>}\n---\n",
        "",
    )
    status, out, _ = _run(capsys, *argv, "--json")
    assert (status, json.loads(out)["position"]) == (0, "<sequence type: double, length: 2>")


def test_text_the_terminal_cannot_show_is_escaped() -> None:
    # PYTHONIOENCODING=ascii (or a latin-1 locale): the first such value ended the command
    # with exit status 2 and "'ascii' codec can't encode character".
    argv = ["topic", "pub", "/snow", "std_msgs/msg/String", "snow \u2603", "--once", "-w", "0"]
    done = subprocess.run(
        [sys.executable, "-m", "pyconnect.cli", *argv],
        check=False,
        capture_output=True,
        timeout=WAIT,
        env=dict(os.environ, PYTHONIOENCODING="ascii"),
    )
    assert (done.returncode, done.stderr) == (0, b"")
    assert done.stdout.splitlines()[-1] == b"publishing #1: 'snow \\u2603'"


def test_a_value_error_at_run_time_is_no_bad_command_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from pyconnect.commands import topic

    def fails(*_args: object) -> int:
        raise UnicodeEncodeError("latin-1", "\u2603", 0, 1, "ordinal not in range(256)")

    monkeypatch.setattr(topic, "_list", fails)
    assert _run(capsys, "topic", "list") == (
        1,
        "",
        "pyconnect: error: 'latin-1' codec can't encode character '\\u2603' in position 0: "
        "ordinal not in range(256)\n",
    )
