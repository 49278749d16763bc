"""export_topic: PNG for images, NPY for arrays, JSON Lines for the rest; progress reported."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
from rclpy.serialization import serialize_message
from sensor_msgs.msg import Image
from std_msgs.msg import Float64MultiArray
from test_msgs.msg import BasicTypes

from pyconnect.record.bag_export import export_topic, export_topics, image_for_png
from pyconnect.record.mcap_recorder import McapRecorder


class CountingBar:
    def __init__(self, total: int, description: str) -> None:
        self.total, self.description, self.count, self.closed = total, description, 0, False

    def update(self, n: int) -> None:
        self.count += n

    def close(self) -> None:
        self.closed = True


def test_export_formats(tmp_path: Path) -> None:
    with McapRecorder(tmp_path / "bag") as recorder:
        recorder.add_topic("/image", "sensor_msgs/msg/Image")
        recorder.add_topic("/basic", "test_msgs/msg/BasicTypes")
        for i in range(3):
            image = Image(height=2, width=2, encoding="mono16", step=4)
            image.data.frombytes(np.full((2, 2), 1000 * i, dtype="<u2").tobytes())
            recorder.write("/image", bytes(serialize_message(image)), log_time_ns=10 + i)
            basic = BasicTypes(int64_value=-i, float32_value=0.5)
            recorder.write("/basic", bytes(serialize_message(basic)), log_time_ns=20 + i)
    bars: list[CountingBar] = []

    def progress(total: int, description: str) -> Any:
        bars.append(CountingBar(total, description))
        return bars[-1]

    result = export_topic(tmp_path / "bag", "/image", tmp_path / "images", progress=progress)
    assert dict(result.files) == {"png": 3}
    assert [(b.total, b.description, b.count, b.closed) for b in bars] == [(3, "/image", 3, True)]
    names = sorted(p.name for p in (tmp_path / "images").iterdir())
    assert names == ["000000_10.png", "000001_11.png", "000002_12.png"]
    pixels = cv2.imread(str(tmp_path / "images" / "000002_12.png"), cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(pixels, np.full((2, 2), 2000, dtype=np.uint16))

    result = export_topic(tmp_path / "bag", "/basic", tmp_path / "basic", progress=progress)
    assert dict(result.files) == {"jsonl": 3}
    lines = (tmp_path / "basic" / "messages.jsonl").read_text().splitlines()
    rows = [json.loads(line) for line in lines]
    assert [(row["log_time_ns"], row["value"]["int64_value"]) for row in rows] == [
        (20, 0),
        (21, -1),
        (22, -2),
    ]
    assert sorted(p.name for p in (tmp_path / "basic").iterdir()) == ["messages.jsonl"]


def test_export_arrays_as_npy(tmp_path: Path) -> None:
    with McapRecorder(tmp_path / "bag.mcap") as recorder:
        recorder.add_topic("/array", "std_msgs/msg/Float64MultiArray")
        message = Float64MultiArray(data=[1.0, 2.5, -3.0])
        recorder.write("/array", bytes(serialize_message(message)), log_time_ns=7)
    result = export_topic(tmp_path / "bag.mcap", "/array", tmp_path / "out", progress=CountingBar)
    if result.files.get("npy"):
        np.testing.assert_array_equal(np.load(tmp_path / "out" / "000000_7.npy"), [1.0, 2.5, -3.0])
    else:  # a natural value that is not an array is a JSON line
        assert dict(result.files) == {"jsonl": 1}


def test_rgb_images_keep_their_colours(tmp_path: Path) -> None:
    rgb = np.zeros((2, 3, 3), dtype=np.uint8)
    rgb[..., 0] = 200  # red
    rgb[0, 0] = (1, 2, 3)
    with McapRecorder(tmp_path / "bag") as recorder:
        recorder.add_topic("/rgb", "sensor_msgs/msg/Image")
        recorder.add_topic("/short", "sensor_msgs/msg/Image")
        image = Image(height=2, width=3, encoding="rgb8", step=9)
        image.data.frombytes(rgb.tobytes())
        recorder.write("/rgb", bytes(serialize_message(image)), log_time_ns=1)
        short = Image(height=2, width=3, encoding="rgb8", step=9)
        short.data.frombytes(b"\x00" * 4)
        recorder.write("/short", bytes(serialize_message(short)), log_time_ns=2)
        recorder.write("/short", bytes(serialize_message(image)), log_time_ns=3)
    result = export_topic(tmp_path / "bag", "/rgb", tmp_path / "out", progress=CountingBar)
    assert dict(result.files) == {"png": 1}
    bgr = cv2.imread(str(tmp_path / "out" / "000000_1.png"), cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(bgr[..., ::-1], rgb)
    result = export_topic(tmp_path / "bag", "/short", tmp_path / "short", progress=CountingBar)
    assert dict(result.files) == {"png": 1}
    assert [(p.topic, p.index, p.log_time_ns) for p in result.errors] == [("/short", 0, 2)]
    assert result.errors[0].reason.startswith("Image.data: expected at least 18 bytes")


def test_topics_whose_names_clean_alike_export_to_distinct_folders(tmp_path: Path) -> None:
    """/cam_/info and /cam/_info both clean to cam___info: one folder held the second topic's
    messages.jsonl only (and mixed their image files)."""
    topics = ["/cam_/info", "/cam/_info", "/a__b", "/a/b"]
    with McapRecorder(tmp_path / "bag") as recorder:
        for k, topic in enumerate(topics):
            recorder.add_topic(topic, "std_msgs/msg/String")
            for i in range(2):
                recorder.write_value(topic, f"{topic} {i}", log_time_ns=10 * k + i)
    out = tmp_path / "out"
    # The order of the topics given does not change where each goes.
    results = export_topics(tmp_path / "bag", topics[::-1], out, progress=lambda *_: _NoBar())
    assert {topic: result.directory for topic, result in results.items()} == {
        "/a/b": out / "a__b",
        "/a__b": out / "a__b_2",
        "/cam/_info": out / "cam___info",
        "/cam_/info": out / "cam___info_2",
    }
    for topic, result in results.items():
        lines = (result.directory / "messages.jsonl").read_text().splitlines()
        assert [json.loads(line)["value"] for line in lines] == [f"{topic} 0", f"{topic} 1"]
    assert export_topics(tmp_path / "bag", topics, out, force=True).keys() == set(topics)


class _NoBar:
    def update(self, n: int) -> None:
        pass

    def close(self) -> None:
        pass


def test_big_endian_16_bit_images_export_as_png(tmp_path: Path) -> None:
    """is_bigendian mono16 pixels decode to ``>u2``: exported as .npy instead of PNG."""
    depth = np.arange(12, dtype=np.uint16).reshape(3, 4) * 1000
    with McapRecorder(tmp_path / "bag") as recorder:
        recorder.add_topic("/depth", "sensor_msgs/msg/Image")
        image = Image(height=3, width=4, encoding="mono16", is_bigendian=True, step=8)
        image.data.frombytes(depth.astype(">u2").tobytes())
        recorder.write("/depth", bytes(serialize_message(image)), log_time_ns=5)
    result = export_topic(tmp_path / "bag", "/depth", tmp_path / "out", progress=CountingBar)
    assert dict(result.files) == {"png": 1}
    pixels = cv2.imread(str(tmp_path / "out" / "000000_5.png"), cv2.IMREAD_UNCHANGED)
    assert pixels.dtype == np.uint16
    np.testing.assert_array_equal(pixels, depth)


def test_image_for_png_gives_native_byte_order() -> None:
    """cv2.imwrite takes native-order pixels only; a big-endian image decodes to ``>u2``."""
    depth = np.arange(6, dtype=np.uint16).reshape(2, 3) * 1000
    fields = {
        "height": 2,
        "width": 3,
        "encoding": "mono16",
        "is_bigendian": 1,
        "step": 6,
        "data": depth.astype(">u2").tobytes(),
    }
    pixels = image_for_png(fields)
    assert pixels.dtype == np.dtype(np.uint16)
    assert pixels.dtype.isnative
    np.testing.assert_array_equal(pixels, depth)


def test_non_finite_floats_export_as_strict_json(tmp_path: Path) -> None:
    # A GPS with no altitude: NaN. messages.jsonl held a bare NaN, which is no JSON.
    from sensor_msgs.msg import NavSatFix
    from std_msgs.msg import Float64

    with McapRecorder(tmp_path / "bag") as recorder:
        recorder.add_topic("/fix", "sensor_msgs/msg/NavSatFix")
        recorder.add_topic("/temp", "std_msgs/msg/Float64")
        fix = NavSatFix(latitude=48.1, altitude=float("nan"))
        recorder.write("/fix", bytes(serialize_message(fix)), log_time_ns=1)
        for stamp, number in enumerate([float("inf"), -float("inf"), 1.5], 2):
            data = bytes(serialize_message(Float64(data=number)))
            recorder.write("/temp", data, log_time_ns=stamp)
    export_topics(tmp_path / "bag", ["/fix", "/temp"], tmp_path / "out")

    def refuse(constant: str) -> None:
        raise ValueError(f"not JSON: {constant}")

    def rows(topic: str) -> list[Any]:
        lines = (tmp_path / "out" / topic / "messages.jsonl").read_text().splitlines()
        return [json.loads(line, parse_constant=refuse)["value"] for line in lines]

    assert [(row["latitude"], row["altitude"]) for row in rows("fix")] == [(48.1, "nan")]
    assert rows("temp") == ["inf", "-inf", 1.5]  # as `bag echo --json` writes them


def test_an_export_of_another_number_of_topics_is_refused_or_replaced(tmp_path: Path) -> None:
    """One topic writes into --to, several into --to/<topic>/: a second export with another
    number of topics was neither refused nor cleaned, and left both exports mixed."""
    from pyconnect.record import BagError

    with McapRecorder(tmp_path / "bag") as recorder:
        for topic in ("/a", "/b"):
            recorder.add_topic(topic, "std_msgs/msg/String")
            recorder.write_value(topic, f"{topic} 0", log_time_ns=1)
    out = tmp_path / "out"

    def files() -> list[str]:
        return sorted(str(p.relative_to(out)) for p in out.rglob("*"))

    def export(topics: list[str], *, force: bool = False) -> None:
        export_topics(tmp_path / "bag", topics, out, force=force, progress=lambda *_: _NoBar())

    export(["/a"])
    with pytest.raises(BagError) as refused:
        export(["/a", "/b"])
    assert str(refused.value) == (
        f"{out}: already holds an export (messages.jsonl); use force=True (--force) to overwrite it"
    )
    assert files() == ["messages.jsonl"]
    (out / "notes.txt").write_text("mine")  # not the export's: kept
    export(["/a", "/b"], force=True)
    assert files() == ["a", "a/messages.jsonl", "b", "b/messages.jsonl", "notes.txt"]

    with pytest.raises(BagError) as refused:
        export(["/b"])
    assert str(refused.value) == (
        f"{out / 'a'}: already holds an export (messages.jsonl); "
        "use force=True (--force) to overwrite it"
    )
    export(["/b"], force=True)
    assert files() == ["messages.jsonl", "notes.txt"]  # the topic folders went with their files
    assert (out / "messages.jsonl").read_text().count("/b 0") == 1
