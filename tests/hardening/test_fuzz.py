"""A short slice of ``make fuzz`` and the crashes it found, each pinned as an exact error."""

from __future__ import annotations

import random
import struct
import tracemalloc
from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from pyconnect.codecs import wire
from pyconnect.codecs.compressed_image import decode_compressed_image
from pyconnect.codecs.point_cloud import decode_point_cloud
from pyconnect.errors import DecodeError
from tests.conftest import require_sample_bags
from tests.record.bag_samples import BAGS
from tools import fuzz

SLICE = 250  # byte strings per family here; `make fuzz` runs 100,000


@pytest.fixture(scope="module")
def families() -> dict[str, list[fuzz.Target]]:
    return fuzz.families(random.Random(7), 3)


@pytest.mark.parametrize(
    "family",
    [
        "generated types",
        "Image (natural)",
        "PointCloud2 (natural)",
        "JointState (natural)",
        "CompressedImage (natural)",
        "bag definitions (on the fly)",
    ],
)
def test_fuzz_slice_finds_nothing(families: dict[str, list[fuzz.Target]], family: str) -> None:
    targets = families[family]
    if family == "bag definitions (on the fly)":
        require_sample_bags(BAGS, any(target.seeds for target in targets))
    fuzz._warm_up(targets)
    tracemalloc.start()
    try:
        tally = fuzz.run_family(family, targets, SLICE, random.Random(family))
    finally:
        tracemalloc.stop()
    assert tally.inputs == SLICE
    # Hangs are timings, which a loaded machine makes up: `make fuzz` reports them.
    assert (tally.crashes, tally.bad_paths, tally.over_allocations) == (0, 0, 0), tally.examples
    assert tally.decoded > 0 and tally.rejected > 0


def error_of(data: bytes, msg_type: str) -> str:
    with pytest.raises(DecodeError) as caught:
        wire.decode(data, msg_type)
    return str(caught.value)


def test_empty_messages_cut_short() -> None:
    # Both used to raise IndexError from the run label of a message with no fields.
    assert error_of(b"\x00\x01\x00\x00", "std_msgs/msg/Empty") == (
        "std_msgs/msg/Empty: truncated at offset 4 (0 bytes left)"
    )
    assert error_of(b"\x00\x00\x00\x7f", "test_msgs/msg/Constants") == (
        "test_msgs/msg/Constants: truncated at offset 4 (0 bytes left)"
    )


def test_header_errors_name_the_type() -> None:
    assert error_of(b"\x00\x01", "sensor_msgs/msg/Image") == (
        "sensor_msgs/msg/Image: 2 bytes is too short for a CDR encapsulation header"
    )


def test_length_of_4_gb_is_a_decode_error_not_a_memory_error() -> None:
    for msg_type, value in (
        ("std_msgs/msg/String", {"data": "abc"}),
        ("sensor_msgs/msg/JointState", {"name": ["a"]}),
        ("diagnostic_msgs/msg/DiagnosticArray", {"status": [{"name": "x"}]}),
    ):
        cdr = bytearray(wire.from_dict(value, msg_type))
        at = len(cdr) - 4
        while at >= 4 and struct.unpack_from("<I", cdr, at)[0] not in (1, 4):
            at -= 4
        cdr[at : at + 4] = b"\xff\xff\xff\xff"
        tracemalloc.start()
        with pytest.raises(DecodeError, match="4294967295"):
            wire.to_dict(bytes(cdr), msg_type)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert peak < 100_000


def cloud(**fields: object) -> SimpleNamespace:
    base = {"height": 1, "width": 1, "point_step": 12, "row_step": 12, "is_bigendian": False,
            "fields": [SimpleNamespace(name="x", offset=0, datatype=7, count=1)],
            "data": np.zeros(12, np.uint8)}  # fmt: skip
    return SimpleNamespace(**{**base, **fields})


def test_point_cloud_impossible_layouts() -> None:
    cases = [
        (cloud(point_step=-12), "PointCloud2.point_step: expected 0 to 2147483646, got -12"),
        (cloud(point_step=2**32 - 1, row_step=2**32 - 1),
         "PointCloud2.point_step: expected 0 to 2147483646, got 4294967295"),
        (cloud(fields=[SimpleNamespace(name="x", offset=2**31, datatype=7, count=1)]),
         "PointCloud2.fields['x']: offset 2147483648 and count 1 must be in [0, 2147483647)"),
        (cloud(fields=[SimpleNamespace(name=5, offset=0, datatype=7, count=1)]),
         "PointCloud2.fields[0].name: expected str, got 5"),
    ]  # fmt: skip
    for msg, expected in cases:
        with pytest.raises(DecodeError) as caught:
            decode_point_cloud(msg)
        assert str(caught.value) == expected


def compressed(form: str, payload: bytes) -> SimpleNamespace:
    return SimpleNamespace(format=form, data=np.frombuffer(payload, np.uint8))


def test_jpeg_claiming_more_pixels_than_its_bytes_hold_is_refused_before_decoding() -> None:
    # OpenCV takes seconds and gigabytes on this 631-byte file (it fills the missing pixels).
    data = bytearray(cv2.imencode(".jpg", np.zeros((8, 8, 3), np.uint8))[1].tobytes())
    at = data.index(b"\xff\xc0")
    struct.pack_into(">HH", data, at + 5, 20000, 30000)
    with pytest.raises(DecodeError) as caught:
        decode_compressed_image(compressed("jpeg", bytes(data)))
    assert str(caught.value) == (
        f"CompressedImage.data: a jpeg header claims 30000 x 20000 pixels, more than "
        f"{len(data)} bytes can hold"
    )


def test_png_claiming_too_many_pixels_or_a_chunk_past_the_end() -> None:
    png = bytearray(cv2.imencode(".png", np.zeros((8, 8), np.uint16))[1].tobytes())
    big = bytearray(png)
    struct.pack_into(">II", big, 16, 40000, 40000)
    with pytest.raises(DecodeError) as caught:
        decode_compressed_image(compressed("png", bytes(big)))
    assert str(caught.value) == (
        f"CompressedImage.data: a png header claims 40000 x 40000 pixels, more than "
        f"{len(big)} bytes can hold"
    )
    # OpenCV 4.11 allocates a chunk's length before reading it (3.4 GB for this one).
    long_chunk = bytearray(png)
    struct.pack_into(">I", long_chunk, 33, 0xF3CCE1FF)
    with pytest.raises(DecodeError) as caught:
        decode_compressed_image(compressed("16UC1; compressedDepth png", bytes(12) + long_chunk))
    assert str(caught.value) == (
        f"CompressedImage.data: cannot decode {len(long_chunk)} bytes as compressedDepth png"
    )
    # The intact image still decodes, 16-bit.
    assert decode_compressed_image(compressed("png", bytes(png))).dtype == np.uint16


def test_multi_array_with_a_zero_and_a_huge_dimension() -> None:
    value = {"layout": {"dim": [{"size": 0, "stride": 0}, {"size": 2**32 - 1, "stride": 1},
                                {"size": 2**32 - 1, "stride": 1}]}}  # fmt: skip
    cdr = wire.from_dict(value, "std_msgs/msg/ByteMultiArray")
    assert error_of(cdr, "std_msgs/msg/ByteMultiArray") == (
        "ByteMultiArray.layout.dim: sizes (0, 4294967295, 4294967295) are too large for an array"
    )


@pytest.mark.parametrize(("ci", "status"), [("", 0), ("true", 1)])
def test_a_family_without_seeds_is_skipped_with_a_line(
    ci: str, status: int, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # A clone without the sample bags has no bag seeds: `make fuzz` died of a ZeroDivisionError
    # after the other families' tables; it says so and goes on (CI, which must have them, fails).
    monkeypatch.setattr(fuzz.fuzz_corpus, "bag_messages", lambda: iter(()))
    monkeypatch.setenv("CI", ci)
    assert fuzz.main(["--count", "5", "--family", "bag"]) == status
    assert "bag definitions (on the fly): skipped, no seed messages" in capsys.readouterr().out
