"""``export_parquet`` into a directory holding an earlier export: refused, or replaced whole."""

from __future__ import annotations

from pathlib import Path

import pyarrow.parquet as pq
import pytest
from sensor_msgs.msg import Image
from std_msgs.msg import Int32

from pyconnect.record import BagError
from pyconnect.record.parquet_export import export_parquet
from tests.record.table_bags import write_bag


def _image_bag(path: Path, frames: int) -> Path:
    messages = []
    for i in range(frames):
        image = Image(height=1, width=2, encoding="mono8", step=2, data=bytes([i, i]))
        messages.append(("/cam/image", 1_000 + i, image))
    return write_bag(path, messages)


def _files(directory: Path) -> list[str]:
    return sorted(path.relative_to(directory).as_posix() for path in directory.rglob("*"))


def test_an_export_of_another_bag_needs_force(tmp_path: Path) -> None:
    # The tables of two bags in one directory read as one export; the files format refuses too.
    first = write_bag(tmp_path / "first", [("/a", 1, Int32(data=1)), ("/b", 2, Int32(data=2))])
    second = write_bag(tmp_path / "second", [("/c", 3, Int32(data=3))])
    out = tmp_path / "out"
    export_parquet(first, out)
    with pytest.raises(BagError) as refused:
        export_parquet(second, out)
    assert str(refused.value) == (
        f"{out}: already holds an export (a.parquet); use force=True (--force) to overwrite it"
    )
    assert _files(out) == ["a.parquet", "b.parquet"]
    (out / "notes.txt").write_text("mine")
    (out / "other.parquet").write_bytes(b"not a table of pyconnect's")
    export_parquet(second, out, force=True)
    assert _files(out) == ["c.parquet", "notes.txt", "other.parquet"]
    assert pq.read_table(out / "c.parquet")["data"].to_pylist() == [3]


def test_force_removes_the_image_files_of_the_earlier_export(tmp_path: Path) -> None:
    # A 2-frame export over a 6-frame one left frames 2..5 beside the new table.
    out = tmp_path / "out"
    export_parquet(_image_bag(tmp_path / "six", 6), out, images="files")
    (out / "cam__image" / "mine.txt").write_text("mine")  # not the export's: kept
    two = _image_bag(tmp_path / "two", 2)
    with pytest.raises(BagError) as refused:
        export_parquet(two, out, images="files")
    assert str(refused.value).startswith(f"{out}: already holds an export (cam__image.parquet); ")
    export_parquet(two, out, images="files", force=True)
    assert _files(out) == [
        "cam__image", "cam__image.parquet", "cam__image/00000000.png", "cam__image/00000001.png",
        "cam__image/mine.txt",
    ]  # fmt: skip
    paths = pq.read_table(out / "cam__image.parquet")["data_path"].to_pylist()
    assert paths == ["cam__image/00000000.png", "cam__image/00000001.png"]


def test_force_removes_the_image_folders_of_another_topic(tmp_path: Path) -> None:
    out = tmp_path / "out"
    export_parquet(_image_bag(tmp_path / "images", 3), out, images="files")
    export_parquet(write_bag(tmp_path / "ints", [("/n", 1, Int32(data=1))]), out, force=True)
    assert _files(out) == ["n.parquet"]


def test_images_of_an_export_stopped_before_its_table_are_an_earlier_export(
    tmp_path: Path,
) -> None:
    out = tmp_path / "out"
    export_parquet(_image_bag(tmp_path / "six", 6), out, images="files")
    (out / "cam__image.parquet").unlink()  # stopped after its images, before its table
    two = _image_bag(tmp_path / "two", 2)
    with pytest.raises(BagError) as refused:
        export_parquet(two, out, images="files")
    assert str(refused.value).startswith(
        f"{out}: already holds an export (cam__image/00000000.png); "
    )
    export_parquet(two, out, images="files", force=True)
    assert _files(out) == [
        "cam__image", "cam__image.parquet", "cam__image/00000000.png", "cam__image/00000001.png",
    ]  # fmt: skip


@pytest.mark.parametrize("images", ["binary", "files"])
def test_a_folder_this_export_writes_no_images_to_is_the_users(tmp_path: Path, images: str) -> None:
    """Frames of the user's own (``%08d.png``, as ffmpeg names them) in a folder named like a
    topic without images: --force deleted them, and the folder."""
    out = tmp_path / "out"
    (out / "n").mkdir(parents=True)
    (out / "n" / "00000000.png").write_bytes(b"mine")
    bag = write_bag(tmp_path / "ints", [("/n", 1, Int32(data=1))])
    export_parquet(bag, out, images=images)  # type: ignore[arg-type]
    export_parquet(bag, out, images=images, force=True)  # type: ignore[arg-type]
    assert _files(out) == ["n", "n.parquet", "n/00000000.png"]
