"""``pyconnect bag export BAG --format parquet --to DIR``: one Parquet file per topic."""

from __future__ import annotations

import sys
from pathlib import Path

import duckdb
import polars as pl
import pytest
from std_msgs.msg import Int8, String

from pyconnect.cli import main
from tests.record.table_bags import write_bag


@pytest.fixture
def bag(tmp_path: Path) -> Path:
    messages = []
    for k in range(3):
        messages.append(("/count", 1_000 + k, Int8(data=-k)))
        messages.append(("/robot/chatter", 1_000 + k, String(data=f"hi {k}")))
    return write_bag(tmp_path / "bag", messages)


def test_every_topic_to_parquet(
    bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "tables"
    assert main(["bag", "export", str(bag), "--format", "parquet", "--to", str(out)]) == 0
    assert capsys.readouterr().out.splitlines() == [
        f"/count: 3 row(s) to {out / 'count.parquet'}",
        f"/robot/chatter: 3 row(s) to {out / 'robot__chatter.parquet'}",
    ]
    assert duckdb.sql(f"SELECT sum(data) FROM '{out / 'count.parquet'}'").fetchall() == [(-3,)]
    frame = pl.read_parquet(out / "robot__chatter.parquet")
    assert frame["data"].to_list() == ["hi 0", "hi 1", "hi 2"]
    assert pl.read_parquet(out / "count.parquet").schema["data"] == pl.Int8


def test_one_topic_to_parquet(
    bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "tables"
    argv = ["bag", "export", str(bag), "--format", "parquet", "--to", str(out), "--topic", "/count"]
    assert main(argv) == 0
    assert sorted(p.name for p in out.iterdir()) == ["count.parquet"]


def test_files_format_still_needs_a_topic(
    bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["bag", "export", str(bag), "--to", str(tmp_path / "x")]) == 2
    assert (
        capsys.readouterr().err
        == "pyconnect: error: the following arguments are required: --topic\n"
    )


def test_without_the_tables_extra_one_line_names_it(
    bag: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # An install without pyarrow: its import fails, and the module importing it is imported anew.
    for name in [name for name in sys.modules if name.split(".")[0] == "pyarrow"]:
        monkeypatch.setitem(sys.modules, name, None)
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    monkeypatch.delitem(sys.modules, "pyconnect.record.parquet_export", raising=False)
    argv = ["bag", "export", str(bag), "--format", "parquet", "--to", str(tmp_path / "tables")]
    assert main(argv) == 2
    assert capsys.readouterr().err == (
        "pyconnect: error: --format parquet needs pyarrow, which cannot be imported: "
        "pip install 'pyconnect-ros[tables]'\n"
    )
