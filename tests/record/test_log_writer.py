"""MessageLogger: file formats, atomic files, bounded queue with counted drops, flush on close."""

from __future__ import annotations

import errno
import io
import json
import logging
import shutil
import threading
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pyconnect.codecs.stamped import Stamped
from pyconnect.errors import EncodeError
from pyconnect.record import log_writer
from pyconnect.record.log_writer import (
    LogWriteError,
    MessageLogger,
    atomic_write_bytes,
    encode_log_value,
)


class GatedWriter:
    """A file writer that waits for ``release`` and records what it was asked to write."""

    def __init__(self) -> None:
        self.release = threading.Event()
        self.entered = threading.Event()
        self.paths: list[Path] = []

    def __call__(self, path: Path, data: bytes) -> None:
        self.entered.set()
        if not self.release.wait(timeout=30):
            raise TimeoutError("test never released the writer")
        atomic_write_bytes(path, data)
        self.paths.append(path)


def files(directory: Path) -> list[str]:
    return sorted(p.name for p in directory.iterdir())


def test_formats_by_value(tmp_path: Path) -> None:
    gray = np.arange(12, dtype=np.uint8).reshape(3, 4)
    depth = np.arange(12, dtype=np.uint16).reshape(3, 4) * 1000
    bgra = np.zeros((2, 2, 4), dtype=np.uint8)
    floats = np.linspace(0, 1, 5)
    cloud = np.zeros(3, dtype=[("x", "<f4"), ("y", "<f4")])
    with MessageLogger(tmp_path) as logger:
        assert logger.log({"a": 1, "t": (1, 2), "b": b"\x00\x01"}, stamp_ns=5)
        assert logger.log(gray, stamp_ns=6)
        assert logger.log(depth, stamp_ns=7)
        assert logger.log(bgra, stamp_ns=8)
        assert logger.log(floats, stamp_ns=9)
        assert logger.log(cloud, stamp_ns=10)
        assert logger.log(b"raw", stamp_ns=11)
        assert logger.log(Stamped((1.0, 2.0), stamp_ns=1234, frame_id="map"))
        assert logger.log("text", stamp_ns=12)
    assert logger.written == 9
    assert files(tmp_path) == [
        "00000001_5.json",
        "00000002_6.png",
        "00000003_7.png",
        "00000004_8.png",
        "00000005_9.npy",
        "00000006_10.npy",
        "00000007_11.bin",
        "00000008_1234.json",
        "00000009_12.json",
    ]
    assert json.loads((tmp_path / "00000001_5.json").read_text()) == {
        "a": 1,
        "t": [1, 2],
        "b": "AAE=",
    }
    np.testing.assert_array_equal(cv2.imread(str(tmp_path / "00000002_6.png"), -1), gray)
    read_depth = cv2.imread(str(tmp_path / "00000003_7.png"), cv2.IMREAD_UNCHANGED)
    assert read_depth.dtype == np.uint16
    np.testing.assert_array_equal(read_depth, depth)
    np.testing.assert_array_equal(np.load(tmp_path / "00000005_9.npy"), floats)
    np.testing.assert_array_equal(np.load(tmp_path / "00000006_10.npy"), cloud)
    assert (tmp_path / "00000007_11.bin").read_bytes() == b"raw"
    assert json.loads((tmp_path / "00000008_1234.json").read_text()) == [1.0, 2.0]
    assert json.loads((tmp_path / "00000009_12.json").read_text()) == "text"


def test_unencodable_value_is_counted_and_logged(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    with caplog.at_level(logging.ERROR, logger="pyconnect.record"), MessageLogger(tmp_path) as log:
        assert log.log(object(), stamp_ns=1)
        assert log.log({"ok": True}, stamp_ns=2)
        assert log.flush(timeout=30)
    assert (log.written, log.failed, log.dropped) == (1, 1, 0)
    assert files(tmp_path) == ["00000002_2.json"]
    assert "value 1 not written: log value: expected a JSON-compatible value, got object" in (
        caplog.text
    )


def test_encode_error_message() -> None:
    with pytest.raises(EncodeError) as caught:
        encode_log_value({"x": {1, object}})
    assert str(caught.value) == "log value: expected a JSON-compatible value, got type"


def test_full_queue_drops_are_counted_and_reported(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    gate = GatedWriter()
    logger = MessageLogger(tmp_path, queue_size=2, write_file=gate)
    with caplog.at_level(logging.WARNING, logger="pyconnect.record"):
        results = [logger.log({"i": i}, stamp_ns=i) for i in range(5)]
        assert gate.entered.wait(timeout=30)
        assert results == [True, True, False, False, False]
        assert (logger.dropped, logger.written, logger.pending) == (3, 0, 2)
        assert not logger.flush(timeout=0)
        gate.release.set()
        logger.close()
    assert (logger.dropped, logger.written, logger.pending) == (3, 2, 0)
    assert files(tmp_path) == ["00000001_0.json", "00000002_1.json"]
    messages = [r.getMessage() for r in caplog.records]
    assert messages == [
        f"{tmp_path}: dropping logged values: queue full (2 pending)",
        f"{tmp_path}: 2 written, 3 dropped (queue full or closed), 0 failed",
    ]


def test_files_appear_atomically(tmp_path: Path) -> None:
    # While the writer is held, nothing (not even a partial file) is visible under a final name.
    gate = GatedWriter()
    logger = MessageLogger(tmp_path, write_file=gate)
    assert logger.log(np.zeros((100, 100), dtype=np.float64), stamp_ns=1)
    assert gate.entered.wait(timeout=30)
    assert files(tmp_path) == []
    gate.release.set()
    logger.close()
    assert files(tmp_path) == ["00000001_1.npy"]


def test_atomic_write_leaves_no_temporary_on_error(tmp_path: Path) -> None:
    with pytest.raises(IsADirectoryError):
        (tmp_path / "target").mkdir()
        atomic_write_bytes(tmp_path / "target", b"x")
    assert files(tmp_path) == ["target"]


def test_close_flushes_and_is_idempotent(tmp_path: Path) -> None:
    logger = MessageLogger(tmp_path, queue_size=1000)
    for i in range(200):
        assert logger.log([i], stamp_ns=i)
    logger.close()
    logger.close()
    assert logger.written == 200
    assert len(files(tmp_path)) == 200
    assert not logger.log([0])
    assert logger.dropped == 1


def test_queue_size_must_be_positive(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"^queue_size: expected an int >= 1, got 0$"):
        MessageLogger(tmp_path, queue_size=0)


json_values = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(min_value=-(2**63), max_value=2**64)
    | st.floats(allow_nan=False, allow_infinity=False)  # non-finite: strings, tested apart
    | st.text(),
    lambda children: (
        st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=5), children, max_size=4)
    ),
    max_leaves=12,
)


@settings(max_examples=60, deadline=None)
@given(json_values)
def test_json_round_trip(value: object) -> None:
    extension, data = encode_log_value(value)
    assert extension == "json"
    assert json.loads(data) == value


@settings(max_examples=40, deadline=None)
@given(
    st.sampled_from([np.uint8, np.uint16]),
    st.integers(1, 6),
    st.integers(1, 6),
    st.sampled_from([None, 1, 3, 4]),
    st.integers(0, 2**32 - 1),
)
def test_png_round_trip(
    dtype: type, height: int, width: int, channels: int | None, seed: int
) -> None:
    shape = (height, width) if channels is None else (height, width, channels)
    top = int(np.iinfo(dtype).max)
    array = np.random.default_rng(seed).integers(0, top, size=shape, dtype=dtype)
    extension, data = encode_log_value(array)
    assert extension == "png"
    decoded = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(decoded, array.reshape(decoded.shape))


def test_big_endian_16_bit_image_is_a_png() -> None:
    """A big-endian mono16 Image decodes to ``>u2`` pixels; they were written as .npy."""
    from sensor_msgs.msg import Image

    from pyconnect import codecs

    depth = np.arange(12, dtype=np.uint16).reshape(3, 4) * 1000
    message = Image(height=3, width=4, encoding="mono16", is_bigendian=True, step=8)
    message.data = depth.astype(">u2").tobytes()
    pixels = codecs.decode(message)
    assert pixels.dtype == np.dtype(">u2")
    extension, data = encode_log_value(pixels)
    assert extension == "png"
    decoded = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    assert decoded.dtype == np.uint16
    np.testing.assert_array_equal(decoded, depth)


def test_big_endian_rgb_pixels_are_a_png_in_bgr_order(tmp_path: Path) -> None:
    rgb = np.zeros((2, 3, 3), dtype=">u2")
    rgb[..., 0] = 60000  # red
    rgb[0, 0] = (1, 2, 3)
    with MessageLogger(tmp_path) as logger:
        assert logger.log(rgb, stamp_ns=1, rgb=True)
    assert files(tmp_path) == ["00000001_1.png"]
    bgr = cv2.imread(str(tmp_path / "00000001_1.png"), cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(bgr[..., ::-1], rgb)


def test_big_endian_non_image_array_keeps_its_byte_order() -> None:
    floats = np.linspace(0, 1, 5).astype(">f8")
    extension, data = encode_log_value(floats)
    assert extension == "npy"
    loaded = np.load(io.BytesIO(data))
    assert loaded.dtype == np.dtype(">f8")
    np.testing.assert_array_equal(loaded, floats)


def _strict_json(data: bytes) -> object:
    def refuse(constant: str) -> None:
        raise ValueError(f"not JSON: {constant}")

    return json.loads(data, parse_constant=refuse)


def test_non_finite_floats_are_strict_json_strings() -> None:
    # Bare NaN/Infinity is no JSON: written as `bag echo --json` writes them.
    value = {
        "altitude": float("nan"),
        "ranges": np.array([1.0, np.inf, -np.inf], dtype=np.float32),
        "pair": (np.float32("nan"), np.float64("-inf")),
        "stamped": Stamped(value=float("inf"), stamp_ns=5, frame_id="gps"),
        "finite": 1.5,
    }
    extension, data = encode_log_value(value)
    assert extension == "json"
    assert _strict_json(data) == {
        "altitude": "nan",
        "ranges": [1.0, "inf", "-inf"],
        "pair": ["nan", "-inf"],
        "stamped": {"value": "inf", "stamp_ns": 5, "frame_id": "gps"},
        "finite": 1.5,
    }
    assert _strict_json(encode_log_value(float("-inf"))[1]) == "-inf"


def test_a_removed_log_folder_is_made_again_and_logging_goes_on(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    # Someone cleaning old logs removed the folder: every later value failed, for ever.
    folder = tmp_path / "root" / "node" / "agent"
    errors: list[LogWriteError] = []
    at_warning = caplog.at_level(logging.WARNING, logger="pyconnect.record")
    with at_warning, MessageLogger(folder, on_error=errors.append) as logger:
        assert logger.log([1], stamp_ns=1)
        assert logger.flush(timeout=30)
        shutil.rmtree(tmp_path / "root")
        for i in range(2, 5):
            assert logger.log([i], stamp_ns=i)
        assert logger.flush(timeout=30)
    assert (logger.written, logger.failed, logger.dropped) == (4, 0, 0)
    assert files(folder) == ["00000002_2.json", "00000003_3.json", "00000004_4.json"]
    assert errors == []
    assert [r.getMessage() for r in caplog.records] == [
        f"{folder}: the log folder was removed; made it again"
    ]


def test_a_log_folder_that_cannot_be_made_again_is_reported_once_and_counted(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    folder = tmp_path / "root" / "agent"
    errors: list[LogWriteError] = []
    with caplog.at_level(logging.DEBUG, logger="pyconnect.record"):
        logger = MessageLogger(folder, on_error=errors.append)
        shutil.rmtree(tmp_path / "root")
        (tmp_path / "root").write_text("a file where the folder was")
        for i in range(1, 6):
            assert logger.log([i], stamp_ns=i)
        assert logger.flush(timeout=30)
        logger.close()
    assert (logger.written, logger.failed, logger.dropped) == (0, 5, 0)
    assert [str(error) for error in errors] == [
        f"{folder}: value 1 not written: the log folder was removed and cannot be made "
        f"again ([Errno 20] Not a directory: '{folder}')"
    ]
    assert isinstance(errors[0].__cause__, OSError)
    warnings = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    assert warnings == [f"{folder}: 0 written, 0 dropped (queue full or closed), 5 failed"]


def test_failures_of_one_kind_are_logged_once_and_counted(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    # A value per line, 200 lines a second under a 200 Hz topic, for as long as it lasted.
    def full_disk(path: Path, data: bytes) -> None:
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    at_warning = caplog.at_level(logging.WARNING, logger="pyconnect.record")
    with at_warning, MessageLogger(tmp_path, write_file=full_disk) as logger:
        for i in range(1, 11):
            assert logger.log([i], stamp_ns=i)
        assert logger.log(object(), stamp_ns=11)  # another kind: reported too
        assert logger.flush(timeout=30)
    assert (logger.written, logger.failed) == (0, 11)
    assert [r.getMessage() for r in caplog.records] == [
        f"{tmp_path}: value 1 not written: [Errno 28] No space left on device: "
        f"'{tmp_path / '00000001_1.json'}' (further failures like it are only counted)",
        f"{tmp_path}: value 11 not written: log value: expected a JSON-compatible value, "
        "got object (further failures like it are only counted)",
        f"{tmp_path}: 0 written, 0 dropped (queue full or closed), 11 failed",
    ]


def test_values_left_when_close_gives_up_are_said_and_counted_as_dropped(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    gate = GatedWriter()
    logger = MessageLogger(tmp_path, write_file=gate)
    with caplog.at_level(logging.WARNING, logger="pyconnect.record"):
        for i in range(4):
            assert logger.log([i], stamp_ns=i)
        assert gate.entered.wait(timeout=30)
        logger.close(timeout=0.01)
        gate.release.set()  # the value being written still is; the three queued are not
        assert logger.flush(timeout=30)
    assert (logger.written, logger.dropped, logger.pending) == (1, 3, 0)
    assert files(tmp_path) == ["00000001_0.json"]
    assert [r.getMessage() for r in caplog.records] == [
        f"{tmp_path}: 3 logged value(s) not written: still queued when close() gave up "
        "(timeout 0.01 s)",
        f"{tmp_path}: 0 written, 3 dropped (queue full or closed), 0 failed",
    ]


def test_the_flush_at_exit_says_what_it_left_unwritten(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    # Values still queued at exit were lost without a word, and the process exited 0.
    gate = GatedWriter()
    logger = MessageLogger(tmp_path, write_file=gate)
    for i in range(5):
        assert logger.log([i], stamp_ns=i)
    assert gate.entered.wait(timeout=30)
    releaser = threading.Timer(0.2, gate.release.set)  # the value being written finishes
    releaser.start()
    with caplog.at_level(logging.WARNING, logger="pyconnect.record"):
        log_writer._flush_open_loggers_at_exit(timeout=0.05)
    releaser.join()
    assert (logger.written, logger.dropped, logger.pending) == (1, 4, 0)
    assert files(tmp_path) == ["00000001_0.json"]
    assert [r.getMessage() for r in caplog.records] == [
        f"{tmp_path}: 4 logged value(s) not written: still queued when the program exited "
        "(the logs get 0.05 s to finish)",
        f"{tmp_path}: 1 written, 4 dropped (queue full or closed), 0 failed",
    ]
