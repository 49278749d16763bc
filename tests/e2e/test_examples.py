"""The seed's and the design's examples run unchanged in two processes; argv remapping applies."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.e2e

ROOT = Path(__file__).resolve().parents[2]
TIMEOUT = 30.0


def _start(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, *args],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )


def _stop(child: subprocess.Popen[str]) -> int:
    if child.poll() is None:
        child.send_signal(2)
    try:
        code = child.wait(TIMEOUT)
    except subprocess.TimeoutExpired:
        child.kill()
        code = child.wait()
    if child.stdout is not None:
        child.stdout.close()
    return code


def test_talker_and_listener_examples() -> None:
    talker = _start("-m", "examples.talker")
    listener = _start("-m", "examples.listener")
    try:
        assert listener.stdout is not None
        line = listener.stdout.readline().strip()
    finally:
        codes = (_stop(listener), _stop(talker))
    assert line.startswith("heard {'cmd': 'forward', 'speed': 0.5, 'count': ")
    assert codes == (0, 0)


def test_the_designs_minimal_example_delivers_every_second() -> None:
    """Run verbatim: a periodic pub with only an ``encode_func`` publishes every period."""
    talker = _start(str(ROOT / "examples" / "minimal_talker.py"))
    listener = _start(str(ROOT / "examples" / "minimal_listener.py"))
    try:
        assert listener.stdout is not None
        lines = [listener.stdout.readline().strip() for _ in range(2)]
    finally:
        codes = (_stop(listener), _stop(talker))
    assert all(line.startswith("received {'status': 'alive', 'time': ") for line in lines), lines
    assert lines[0] != lines[1]
    assert codes == (0, 0)


def test_remapping_from_the_command_line(tmp_path: Path) -> None:
    script = tmp_path / "remapped.py"
    script.write_text(
        "from std_msgs.msg import String\n"
        "from pyconnect.ros.custom_node import CustomNode\n"
        "with CustomNode('remapped') as node:\n"
        "    agent = node.add_agent(conn_name='chatter', conn_type='pub', data_interface=String)\n"
        "    print(agent.topic, node.get_param('rate'), flush=True)\n"
    )
    child = _start(str(script), "--ros-args", "-r", "chatter:=talk", "-p", "rate:=5")
    assert child.stdout is not None
    out = child.stdout.read()
    assert _stop(child) == 0
    assert out.strip() == "/talk 5"


def test_the_demo_ends_cleanly_and_writes_its_logs(tmp_path: Path) -> None:
    """README: ``make demo`` (``python -m examples.demo``) runs the simulated robot and the
    brain, ends with exit status 0, and logs to ``./pyconnect_logs``. Runs in a domain of its
    own (the one after the test run's), from ``tmp_path`` so the logs land there."""
    run_domain = int(os.environ["ROS_DOMAIN_ID"])
    env = {key: value for key, value in os.environ.items() if key != "PYCONNECT_LOG_DIR"}
    env["ROS_DOMAIN_ID"] = str(run_domain + 1 if run_domain < 232 else run_domain - 1)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))
    env["PYTHONUNBUFFERED"] = "1"
    done = subprocess.run(
        [sys.executable, "-m", "examples.demo"], cwd=tmp_path, env=env,
        capture_output=True, text=True, timeout=240, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    logs = tmp_path / "pyconnect_logs" / "demo_brain"
    assert f"[brain] logs in {logs}" in done.stdout
    assert done.stdout.rstrip().endswith("[demo] robot exited with 0; done")
    (session,) = logs.iterdir()  # <YYYYmmdd-HHMMSS>
    # do_log_msg on joint_states, start_log_subs for the rest: dicts as JSON, images as PNG.
    expected = {"joint_states": "*.json", "scan": "*.json", "camera__image": "*.png"}
    for agent, files in expected.items():
        assert any((session / agent).glob(files)), sorted(session.rglob("*"))[:20]
