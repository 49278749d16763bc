"""Every ```python block of README.md runs, each in a process of its own.

How a block runs: the harness below, then the block's ``Setup.prelude`` (names a fragment
takes for granted, files it reads), then the block's text compiled as ``README.md`` at its
own line numbers (tracebacks point into the README). A block that ends in a blocking
``spin()`` is stopped with Ctrl-C once it spins, and must exit 0 like a user's program. A block
that talks to a live graph gets a ``Setup.peer``: a script that provides the other side and
prints READY.

Adding a README block: if it runs on its own, nothing to do. If it is a fragment or needs a
peer, add a ``SETUPS`` entry keyed by one line of the block (any line that identifies it).
"""

from __future__ import annotations

import os
import queue
import re
import signal
import subprocess
import sys
import threading
from dataclasses import dataclass
from pathlib import Path

import pytest

pytestmark = pytest.mark.e2e

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
TIMEOUT = 60.0
SPINNING = "README-HARNESS: spinning"

HARNESS = f"""
from pyconnect.ros.custom_node import CustomNode as _CustomNode

_spin = _CustomNode.spin


def _announcing_spin(self, run_thread=False):
    if not run_thread:
        print({SPINNING!r}, flush=True)
    return _spin(self, run_thread)


_CustomNode.spin = _announcing_spin
"""


@dataclass(frozen=True)
class Setup:
    prelude: str = ""
    """Python run before the block (imports and values a fragment assumes)."""
    peer: str = ""
    """A script run beside the block; it prints READY when its side of the graph is up."""


AGENTS_PEER = """
from nav_msgs.msg import OccupancyGrid
from nav_msgs.srv import GetMap
import numpy as np
from sensor_msgs.msg import Image
from pyconnect.ros.custom_node import CustomNode

map_response = GetMap.Response(map=OccupancyGrid())
map_response.map.info.width, map_response.map.info.height = 4, 2
map_response.map.data = [0] * 8
with CustomNode("readme_peer") as node:
    node.add_agent(conn_name="camera_image", conn_type="pub", data_interface=Image,
                   time_period=0.1, response_func=lambda: np.zeros((4, 6, 3), np.uint8))
    node.add_agent(conn_name="get_map", conn_type="service_server", data_interface=GetMap,
                   response_func=lambda _request: map_response)
    node.spin(run_thread=True)
    print("READY", flush=True)
    node.wait_for_shutdown()
"""


# Tables: bags with camera images and joint states, stamped 0.1 s apart, joints 5 ms late.
RUN_BAGS = """
import numpy as np
from rclpy.serialization import serialize_message
from sensor_msgs.msg import Image, JointState
from pyconnect import codecs
from pyconnect.record.mcap_recorder import McapRecorder


def _write_run_bags():
    for name in ("run2", "run3"):
        with McapRecorder(name) as recorder:
            recorder.add_topic("/camera/image_raw", "sensor_msgs/msg/Image")
            recorder.add_topic("/joint_states", "sensor_msgs/msg/JointState")
            for k in range(5):
                t = 1_700_000_000_000_000_000 + k * 100_000_000
                image = codecs.encode(np.full((2, 3, 3), k, np.uint8), Image)
                image.header.stamp.sec, image.header.stamp.nanosec = divmod(t, 10**9)
                joints = JointState(name=["elbow"], position=[0.1 * k])
                joints.header.stamp.sec, joints.header.stamp.nanosec = divmod(t + 5_000_000, 10**9)
                recorder.write("/camera/image_raw", serialize_message(image), log_time_ns=t)
                recorder.write("/joint_states", serialize_message(joints), log_time_ns=t + 5_000_000)


if __name__ == "__main__":  # not again in Dask's worker processes, which re-run the script
    _write_run_bags()
"""

SETUPS: dict[str, Setup] = {
    # Codecs: a message, its CDR bytes and a user codec.
    "codec = codecs.lookup(Image)": Setup(
        prelude="""
import numpy as np
from rclpy.serialization import serialize_message
from sensor_msgs.msg import Image
from pyconnect import codecs
from pyconnect.codecs.image import ImageCodec

msg = codecs.encode(np.zeros((2, 3, 3), np.uint8), Image)
cdr_bytes = serialize_message(msg)


class MyCodec(ImageCodec):
    "A user's codec."
"""
    ),
    # Agents: a camera and a map server to connect to.
    'node = CustomNode(name="my_robot_node")': Setup(peer=AGENTS_PEER),
    # Bags: a recorded bag called run1.
    'open_bag("run1"': Setup(
        prelude="""
import numpy as np
from rclpy.serialization import serialize_message
from sensor_msgs.msg import Image
from pyconnect import codecs
from pyconnect.record.mcap_recorder import McapRecorder

with McapRecorder("run1") as _recorder:
    _recorder.add_topic("/camera/image_raw", "sensor_msgs/msg/Image")
    _image = serialize_message(codecs.encode(np.zeros((2, 3, 3), np.uint8), Image))
    _recorder.write("/camera/image_raw", _image, log_time_ns=1)
"""
    ),
    # Tables and Dask: run2 and run3 (RUN_BAGS).
    'align("run2"': Setup(prelude=RUN_BAGS),
    'images="files"': Setup(prelude=RUN_BAGS),
    'read_bags(["run2", "run3"]': Setup(prelude=RUN_BAGS),
}


@dataclass(frozen=True)
class Block:
    line: int
    """Line of the block's first code line in README.md."""
    heading: str
    text: str

    @property
    def where(self) -> str:
        return f"README.md block at line {self.line} (under {self.heading!r})"


def python_blocks() -> list[Block]:
    blocks: list[Block] = []
    heading = "(top)"
    lines = README.read_text().splitlines()
    index = 0
    while index < len(lines):
        line = lines[index]
        if line.startswith("#") and not line.startswith("#!"):
            heading = line.strip()
        fence = re.match(r"^```(\w*)\s*$", line)
        if fence:
            end = index + 1
            while end < len(lines) and lines[end].strip() != "```":
                end += 1
            if fence.group(1) == "python":
                blocks.append(Block(index + 2, heading, "\n".join(lines[index + 1 : end])))
            index = end
        index += 1
    return blocks


def setup_of(block: Block) -> Setup:
    found = [setup for key, setup in SETUPS.items() if key in block.text]
    if len(found) > 1:
        raise AssertionError(f"{block.where}: more than one SETUPS key matches it")
    return found[0] if found else Setup()


def test_every_setup_still_matches_a_block() -> None:
    texts = [block.text for block in python_blocks()]
    stale = [key for key in SETUPS if not any(key in text for text in texts)]
    assert stale == [], f"SETUPS keys no README block contains any more: {stale}"


@pytest.mark.parametrize("block", python_blocks(), ids=lambda block: f"line{block.line}")
def test_readme_block_runs(block: Block, tmp_path: Path) -> None:
    setup = setup_of(block)
    source = tmp_path / "block.txt"
    source.write_text("\n" * (block.line - 1) + block.text)
    script = tmp_path / "block.py"
    script.write_text(
        f"{HARNESS}\n{setup.prelude}\n"
        "import pathlib\n"
        f"_text = pathlib.Path({str(source)!r}).read_text()\n"
        f"exec(compile(_text, {str(README)!r}, 'exec'))\n"
    )
    peer = _start_peer(setup.peer, tmp_path) if setup.peer else None
    try:
        code, output = _run_block(script, tmp_path)
    finally:
        if peer is not None:
            _stop(peer)
    assert code == 0, (
        f"{block.where} failed (exit code {code}). If it is a fragment or needs a peer, add a "
        f"SETUPS entry in {Path(__file__).name}.\n{output[-3000:]}"
    )


def _env() -> dict[str, str]:
    return {**os.environ, "PYTHONUNBUFFERED": "1", "PYCONNECT_LOG_DIR": "logs"}


def _start_peer(text: str, directory: Path) -> subprocess.Popen[str]:
    script = directory / "peer.py"
    script.write_text(text)
    peer = subprocess.Popen(
        [sys.executable, str(script)],
        cwd=directory,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=_env(),
    )
    assert peer.stdout is not None
    first = peer.stdout.readline().strip()
    if first != "READY":
        _stop(peer)
        raise AssertionError(f"the README peer did not start: {first!r}")
    return peer


def _run_block(script: Path, directory: Path) -> tuple[int, str]:
    """Run the block; Ctrl-C it once it spins. (exit code, everything it printed)."""
    child = subprocess.Popen(
        [sys.executable, str(script)],
        cwd=directory,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=_env(),
    )
    assert child.stdout is not None
    lines: queue.Queue[str | None] = queue.Queue()

    def read(stream: object) -> None:
        for line in stream:  # type: ignore[attr-defined]
            lines.put(line)
        lines.put(None)

    reader = threading.Thread(target=read, args=(child.stdout,), daemon=True)
    reader.start()
    output: list[str] = []
    while True:
        try:
            line = lines.get(timeout=TIMEOUT)
        except queue.Empty:
            output.append(f"[harness: nothing printed for {TIMEOUT} s; killed]\n")
            child.kill()
            break
        if line is None:
            break
        output.append(line)
        if line.strip() == SPINNING:
            child.send_signal(signal.SIGINT)
    code = _wait(child)
    reader.join(TIMEOUT)
    child.stdout.close()
    return code, "".join(output)


def _wait(child: subprocess.Popen[str]) -> int:
    try:
        return child.wait(TIMEOUT)
    except subprocess.TimeoutExpired:
        child.kill()
        return child.wait()


def _stop(child: subprocess.Popen[str]) -> None:
    if child.poll() is None:
        child.send_signal(signal.SIGINT)
    _wait(child)
    if child.stdout is not None:
        child.stdout.close()
