"""``pyconnect bag export`` (files format) of a damaged bag: the damage summary on stderr."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from pyconnect.cli import main
from tests.conftest import require_sample_bags
from tests.record.bag_samples import BAGS

WBAG_1 = BAGS / "ros2_rosbag2_jazzy/rosbag2_py/test/resources/sqlite3/wbag/wbag_1.db3"


def test_the_summary_counts_the_messages_of_every_exported_topic(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    require_sample_bags(WBAG_1, WBAG_1.is_file())
    bag = tmp_path / "cut.db3"
    bag.write_bytes(WBAG_1.read_bytes()[:66584])  # cut inside the messages table
    argv = ["bag", "export", str(bag), "--topic", "AAA", "--topic", "BBB", "--to"]
    assert main([*argv, str(tmp_path / "out")]) == 1
    captured = capsys.readouterr()
    exported = [int(m) for m in re.findall(r"^\w+: (\d+) message\(s\) to ", captured.out, re.M)]
    assert len(exported) == 2 and all(exported)
    summary = captured.err.splitlines()[0]
    assert summary.startswith(f"pyconnect: {bag}: damaged bag: {bag} at byte")
    assert f"; {sum(exported)} message(s) read, " in summary
