"""``pyconnect bag play`` (``pyconnect.commands.bag_play``) with nothing to play: an error or an
end, never a silent success or a busy loop."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from rclpy.serialization import serialize_message
from std_msgs.msg import String

from pyconnect.cli import main
from pyconnect.record.mcap_recorder import McapRecorder
from tests.commands.processes import ROOT, WAIT


@pytest.fixture(scope="module")
def short_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    bag = tmp_path_factory.mktemp("play") / "short"
    with McapRecorder(bag) as recorder:
        recorder.add_topic("/said", "std_msgs/msg/String")
        for k in range(3):
            data = serialize_message(String(data=f"said {k}"))
            recorder.write("/said", data, log_time_ns=1_000_000_000 + k * 1_000_000)
    return bag


def test_play_of_a_topic_not_in_the_bag_is_an_error(
    short_bag: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # It played nothing and exited 0: a typo looked like a success.
    assert main(["bag", "play", str(short_bag), "--topics", "/said", "/nope", "/nix"]) == 1
    captured = capsys.readouterr()
    assert captured.err == (
        f"pyconnect: error: {short_bag}: no topic /nope, /nix in this bag (topics: /said)\n"
    )
    assert "Playing" not in captured.out


@pytest.mark.parametrize("loop", [[], ["--loop"]])
def test_play_with_nothing_to_play_ends_with_a_warning(short_bag: Path, loop: list[str]) -> None:
    # With --loop it reopened the bag at once, again and again, at 100 % CPU for ever.
    argv = ["bag", "play", str(short_bag), *loop, "--start-offset", "100"]
    done = subprocess.run(
        [sys.executable, "-m", "pyconnect.cli", *argv],
        check=False,
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=WAIT,
    )
    assert (done.returncode, done.stderr) == (
        0,
        f"pyconnect: warning: nothing to play: {short_bag} has no message "
        "from --start-offset 100 s on\n",
    )
    assert done.stdout == f"Playing {short_bag} (1 topic(s))\n"
