"""Peers in their own processes: rclpy blocked, Ctrl-C and SIGTERM exit 0 without a traceback."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from tests.transport.conftest import PeerFactory, loopback_config

SCRIPT = Path(__file__).with_name("peer_without_rclpy.py")
REPO = Path(__file__).resolve().parents[2]
TIMEOUT = 60.0


def start(config: Path, role: str, topic: str) -> subprocess.Popen[str]:
    process = subprocess.Popen(
        [sys.executable, str(SCRIPT), str(config), role, topic],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=REPO,
        env={**os.environ, "PYTHONPATH": str(REPO)},
    )
    assert process.stdout is not None
    line = process.stdout.readline()
    if line.strip() != "ready":
        process.kill()
        _out, err = process.communicate()
        raise AssertionError(f"peer process did not start: {line!r} {err}")
    return process


def test_a_peer_without_rclpy_exchanges_images(
    make_peer: PeerFactory, locator: str, tmp_path: Path
) -> None:
    here = make_peer("robot")
    config = tmp_path / "session.json5"
    config.write_text(loopback_config(connect=locator))
    back = threading.Event()
    here.add_agent(
        conn_name="camera_back",
        conn_type="sub",
        data_interface="sensor_msgs/msg/Image",
        response_func=lambda _v: back.set(),
    )
    camera = here.add_agent(
        conn_name="camera", conn_type="pub", data_interface="sensor_msgs/msg/Image"
    )
    process = start(config, "echo-image", "camera")
    try:
        assert here.wait_for_graph(lambda: camera.subscriber_count == 1, None)
        image = np.random.default_rng(2).integers(0, 255, (120, 160, 3), dtype=np.uint8)
        camera.send(image)
        assert back.wait(TIMEOUT)
        np.testing.assert_array_equal(here.agents["camera_back"].get(), image)
    finally:
        process.send_signal(signal.SIGINT)
        out, err = process.communicate(timeout=TIMEOUT)
    assert process.returncode == 0, err
    assert out.strip() == "False"  # rclpy never got imported
    assert "Traceback" not in err


def test_a_peer_without_rclpy_serves_an_action(
    make_peer: PeerFactory, locator: str, tmp_path: Path
) -> None:
    here = make_peer("laptop")
    config = tmp_path / "session.json5"
    config.write_text(loopback_config(connect=locator))
    feedback: list[object] = []
    client = here.add_agent(
        conn_name="fib",
        conn_type="action_client",
        data_interface="test_msgs/action/Fibonacci",
        feedback_func=feedback.append,
    )
    process = start(config, "fibonacci-server", "fib")
    try:
        result = client.send({"order": 3}, timeout=TIMEOUT)
        assert result == {"sequence": [0, 1, 1, 2, 3], "isdone": True}
    finally:
        process.send_signal(signal.SIGINT)
        out, err = process.communicate(timeout=TIMEOUT)
    assert process.returncode == 0, err
    assert out.strip() == "False"  # rclpy never got imported
    assert "Traceback" not in err


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_ends_a_spinning_peer_with_exit_0(
    signum: int, locator: str, tmp_path: Path
) -> None:
    config = tmp_path / "session.json5"
    config.write_text(loopback_config(listen=locator))
    process = start(config, "spin", "unused")
    process.send_signal(signum)
    out, err = process.communicate(timeout=TIMEOUT)
    assert process.returncode == 0, err
    assert err == ""
    del out  # the signal may come before spin() (SystemExit(0)) or during it (spin returns)


def finish(process: subprocess.Popen[str]) -> tuple[str, str]:
    """The rest of stdout and all of stderr of a process that ended with exit status 0
    (``communicate()`` would skip what ``readline()`` has buffered already)."""
    assert process.stdout is not None and process.stderr is not None
    with process.stdout, process.stderr:
        out = process.stdout.read()
        process.wait(TIMEOUT)
        err = process.stderr.read()
    assert process.returncode == 0, err  # not SIGABRT, not an exception
    return out, err


def test_a_script_that_never_shuts_its_peer_down_still_exits(locator: str, tmp_path: Path) -> None:
    """zenoh's callback threads are not daemons: the peer shuts down when the main thread ends."""
    config = tmp_path / "session.json5"
    config.write_text(loopback_config(listen=locator))
    out, err = finish(start(config, "no-shutdown", "chatter"))
    assert (out.strip(), err) == ("False", "")  # stop_func ran


def test_a_handler_that_shuts_its_peer_down_still_answers(
    make_peer: PeerFactory, locator: str, tmp_path: Path
) -> None:
    here = make_peer("operator")
    config = tmp_path / "session.json5"
    config.write_text(loopback_config(connect=locator))
    stop = here.add_agent(
        conn_name="stop", conn_type="service_client", data_interface="std_srvs/srv/Trigger"
    )
    process = start(config, "stop-service", "stop")
    try:
        here.wait_until_connected(timeout=TIMEOUT)
        assert stop.send() == {"success": True, "message": "stopping", "isdone": True}
        out, err = finish(process)  # exit 0: no thread left inside zenoh at exit
    finally:
        process.kill()
    assert (out.strip(), err) == ("False", "")


def test_a_second_peer_in_the_process_ends_on_a_signal_too(locator: str, tmp_path: Path) -> None:
    config = tmp_path / "session.json5"
    config.write_text(loopback_config(listen=locator))
    process = start(config, "spin-twice", "unused")
    assert process.stdout is not None
    process.send_signal(signal.SIGTERM)
    assert process.stdout.readline().strip() == "False"  # the first peer's stop_func
    assert process.stdout.readline().strip() == "ready"
    process.send_signal(signal.SIGTERM)  # a first signal again, not a second Ctrl-C
    out, err = finish(process)
    assert (out.strip(), err) == ("again", "")


def test_what_a_peer_reports_reaches_stderr_unconfigured(locator: str, tmp_path: Path) -> None:
    """A program that never configures logging still sees a handler's failure (stderr)."""
    config = tmp_path / "session.json5"
    config.write_text(loopback_config(listen=locator))
    out, err = finish(start(config, "raising-sub", "words"))
    assert out.strip() == "False"
    assert (
        "agent 'words' (sub std_msgs/msg/String): response_func raised RuntimeError: no use for it"
        in err
    )
