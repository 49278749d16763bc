"""A short slice of ``make storm``: one busy node per ending, each ended cleanly."""

from __future__ import annotations

from pathlib import Path

import pytest

from tools import storm

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("ending", storm.ENDINGS)
def test_busy_node_ends_cleanly(ending: str, tmp_path: Path) -> None:
    run = storm.one_run(ending, 0.3, tmp_path, REPO)
    assert (run.code, run.problems) == (0, []), (tmp_path / "stdout.txt").read_text()
    assert run.log_files > 0  # the image subscriber logged while everything was busy
