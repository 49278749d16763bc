"""Tables with images as files: ``to_arrow(topic, images="files", image_dir=...)`` and
``bag export --format parquet --images files`` write lossless PNG/NPY files and a path column."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2
import duckdb
import numpy as np
import polars as pl
import pyarrow as pa
import pytest
from sensor_msgs.msg import Image
from stereo_msgs.msg import DisparityImage

from pyconnect.cli import main
from pyconnect.record import open_bag
from pyconnect.record.parquet_export import export_parquet
from tests.record.table_bags import write_bag

T0 = 1_700_000_000_000_000_000
RNG = np.random.default_rng(7)


def _image(array: np.ndarray, encoding: str, *, step_pad: int = 0, big: bool = False) -> Image:
    height, width = array.shape[:2]
    row = array.reshape(height, -1)
    if big:
        row = row.astype(row.dtype.newbyteorder(">"))
    raw = row.view(np.uint8).reshape(height, -1)
    padded = np.zeros((height, raw.shape[1] + step_pad), np.uint8)
    padded[:, : raw.shape[1]] = raw
    msg = Image(height=height, width=width, encoding=encoding, step=padded.shape[1])
    msg.is_bigendian = int(big)
    msg.data = padded.tobytes()
    return msg


# (encoding, array as the natural value gives it, extension, how the image was stored)
CASES: list[tuple[str, np.ndarray, str, dict[str, Any]]] = [
    ("rgb8", RNG.integers(0, 256, (4, 5, 3), dtype=np.uint8), "png", {}),
    ("bgr8", RNG.integers(0, 256, (4, 5, 3), dtype=np.uint8), "png", {"step_pad": 3}),
    ("mono8", RNG.integers(0, 256, (4, 5), dtype=np.uint8), "png", {}),
    ("rgba8", RNG.integers(0, 256, (3, 2, 4), dtype=np.uint8), "png", {}),
    ("mono16", RNG.integers(0, 65536, (4, 5), dtype=np.uint16), "png", {}),
    ("16UC1", RNG.integers(0, 65536, (4, 5), dtype=np.uint16), "png", {"big": True}),
    ("rgb16", RNG.integers(0, 65536, (2, 3, 3), dtype=np.uint16), "png", {}),
    ("32FC1", RNG.random((4, 5), dtype=np.float32), "npy", {}),
    ("16SC1", RNG.integers(-32768, 32768, (4, 5), dtype=np.int16), "npy", {}),
    ("yuv422", RNG.integers(0, 256, (2, 4, 2), dtype=np.uint8), "npy", {}),
]


def _read_back(path: Path, encoding: str) -> np.ndarray:
    if path.suffix == ".npy":
        array: np.ndarray = np.load(path, allow_pickle=False)
        return array
    array = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if encoding.startswith("rgba"):
        return cv2.cvtColor(array, cv2.COLOR_BGRA2RGBA)
    if encoding.startswith("rgb"):
        return cv2.cvtColor(array, cv2.COLOR_BGR2RGB)
    return array


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    messages: list[tuple[str, int, Any]] = []
    for i, (encoding, array, _ext, options) in enumerate(CASES):
        messages.append(("/camera/image", T0 + i, _image(array, encoding, **options)))
    broken = Image(height=2, width=2, encoding="no-such-encoding", step=2, data=b"\x01\x02\x03")
    messages.append(("/camera/image", T0 + len(CASES), broken))
    disparity = DisparityImage(min_disparity=1.0, max_disparity=64.0)
    disparity.image = _image(CASES[7][1], "32FC1")
    messages.append(("/stereo/disparity", T0, disparity))
    return write_bag(tmp_path_factory.mktemp("image_files") / "bag", messages)


def test_images_become_lossless_files_and_a_path_column(bag: Path, tmp_path: Path) -> None:
    with open_bag(bag) as reader:
        table = reader.to_arrow("/camera/image", images="files", image_dir=tmp_path)
    assert "data" not in table.column_names
    assert table.schema.field("data_path").type == pa.string()
    assert table.schema.metadata[b"images"] == b"files"
    rows = table.to_pylist()
    expected_paths = [
        f"camera__image/{row:08d}.{ext}" for row, (_, _, ext, _) in enumerate(CASES)
    ] + [f"camera__image/{len(CASES):08d}.bin"]
    assert [row["data_path"] for row in rows] == expected_paths
    for row, (encoding, array, _ext, _options) in zip(rows, CASES, strict=False):
        assert row["encoding"] == encoding
        back = _read_back(tmp_path / row["data_path"], encoding)
        assert back.dtype == array.dtype.newbyteorder("="), encoding
        np.testing.assert_array_equal(back, array, err_msg=encoding)
    # An encoding nobody knows: its bytes as stored, the columns beside say the rest.
    assert (tmp_path / rows[-1]["data_path"]).read_bytes() == b"\x01\x02\x03"


def test_rgb_files_show_their_colours_in_png_order(bag: Path, tmp_path: Path) -> None:
    with open_bag(bag) as reader:
        table = reader.to_arrow("/camera/image", images="files", image_dir=tmp_path)
    rgb = cv2.imread(str(tmp_path / table.column("data_path")[0].as_py()), cv2.IMREAD_UNCHANGED)
    bgr = cv2.imread(str(tmp_path / table.column("data_path")[1].as_py()), cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(rgb[..., ::-1], CASES[0][1])  # OpenCV reads PNGs as BGR
    np.testing.assert_array_equal(bgr, CASES[1][1])


def test_a_nested_image_gets_its_own_folder(bag: Path, tmp_path: Path) -> None:
    with open_bag(bag) as reader:
        frame = reader.to_polars("/stereo/disparity", images="files", image_dir=tmp_path)
    assert "image.data" not in frame.columns
    (path,) = frame["image.data_path"].to_list()
    assert path == "stereo__disparity/image/00000000.npy"
    np.testing.assert_array_equal(np.load(tmp_path / path), CASES[7][1])
    assert frame["max_disparity"].to_list() == [64.0]


def test_parquet_export_paths_are_relative_to_the_parquet_file(
    bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "tables"
    argv = ["bag", "export", str(bag), "--format", "parquet", "--to", str(out)]
    assert main([*argv, "--images", "files"]) == 0
    assert capsys.readouterr().out.splitlines() == [
        f"/camera/image: {len(CASES) + 1} row(s) to {out / 'camera__image.parquet'}",
        f"/stereo/disparity: 1 row(s) to {out / 'stereo__disparity.parquet'}",
    ]
    parquet = out / "camera__image.parquet"
    frame = pl.read_parquet(parquet)
    assert frame.schema["data_path"] == pl.String
    query = f"SELECT encoding, data_path FROM '{parquet}' ORDER BY log_time_ns"
    from_duckdb = duckdb.sql(query).fetchall()
    assert from_duckdb == list(zip(frame["encoding"], frame["data_path"], strict=True))
    for (encoding, path), (_, array, _, _) in zip(from_duckdb, CASES, strict=False):
        np.testing.assert_array_equal(_read_back(parquet.parent / path, encoding), array)


def test_the_default_keeps_images_binary(bag: Path, tmp_path: Path) -> None:
    result = export_parquet(bag, tmp_path, topics=["/camera/image"])
    assert pl.read_parquet(result.files["/camera/image"][0]).schema["data"] == pl.Binary
    assert sorted(p.name for p in tmp_path.iterdir()) == ["camera__image.parquet"]


def test_bad_image_options_are_errors(bag: Path, tmp_path: Path) -> None:
    with open_bag(bag) as reader:
        with pytest.raises(ValueError) as no_dir:
            reader.to_arrow("/camera/image", images="files")
        with pytest.raises(ValueError) as unknown:
            reader.to_arrow("/camera/image", images="png")  # type: ignore[arg-type]
        with pytest.raises(ValueError) as stray:
            reader.to_arrow("/camera/image", image_dir=tmp_path)
    assert str(no_dir.value) == "images='files' needs image_dir, the directory to write them to"
    assert str(unknown.value) == "images: expected 'binary' or 'files', got 'png'"
    assert str(stray.value) == "image_dir is only for images='files'"


def test_images_option_is_for_parquet_only(
    bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["bag", "export", str(bag), "--topic", "/camera/image", "--to", str(tmp_path / "x")]
    assert main([*argv, "--images", "files"]) == 2
    assert capsys.readouterr().err == "pyconnect: error: --images is for --format parquet\n"


def test_topics_whose_names_clean_alike_get_their_own_files(tmp_path: Path) -> None:
    """/cam_/img and /cam/_img both clean to cam___img: one Parquet file and one image folder
    held the second topic over the first."""
    first, second = CASES[0][1], CASES[1][1]
    messages: list[tuple[str, int, Any]] = [
        ("/cam_/img", T0, _image(first, CASES[0][0])),
        ("/cam/_img", T0 + 1, _image(second, CASES[1][0])),
    ]
    bag = write_bag(tmp_path / "bag", messages)
    out = tmp_path / "tables"
    result = export_parquet(bag, out, images="files")
    assert {topic: path.name for topic, (path, _rows) in result.files.items()} == {
        "/cam/_img": "cam___img.parquet",
        "/cam_/img": "cam___img_2.parquet",
    }
    for topic, array, encoding in (
        ("/cam_/img", first, CASES[0][0]),
        ("/cam/_img", second, CASES[1][0]),
    ):
        path, _rows = result.files[topic]
        (image_path,) = pl.read_parquet(path)["data_path"].to_list()
        assert image_path.split("/")[0] == path.stem  # its own folder, named as its file
        np.testing.assert_array_equal(_read_back(out / image_path, encoding), array)
