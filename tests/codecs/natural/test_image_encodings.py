"""``pixel_format`` and the generic encoding names: cv_bridge's ``getCvType`` rules."""

from __future__ import annotations

import numpy as np
import pytest

from pyconnect.codecs.image_encodings import (
    NAMED_ENCODINGS,
    UnknownEncodingError,
    generic_encoding,
    infer_encoding,
    pixel_format,
)


@pytest.mark.parametrize(
    ("encoding", "dtype", "channels"),
    [("32F", np.float32, 1), ("16U", np.uint16, 1), ("8S", np.int8, 1), ("8UC5", np.uint8, 5),
     ("32FC6", np.float32, 6), ("64FC512", np.float64, 512), ("16SC10", np.int16, 10)],
)  # fmt: skip
def test_bare_depths_and_any_channel_count(encoding: str, dtype: type, channels: int) -> None:
    fmt = pixel_format(encoding)
    assert (fmt.dtype, fmt.channels, fmt.rows_per_row) == (np.dtype(dtype), channels, 1)


def test_channel_counts_outside_opencvs_range_are_refused() -> None:
    for encoding, channels in (("32FC513", 513), ("8UC999", 999)):
        with pytest.raises(UnknownEncodingError) as error:
            pixel_format(encoding)
        assert str(error.value) == (
            f"image encoding {encoding!r}: expected 1 to 512 channels (OpenCV's CV_CN_MAX), "
            f"got {channels}"
        )
    for encoding in ("8UC", "8UC0", "8UC1000"):
        with pytest.raises(UnknownEncodingError) as unknown:
            pixel_format(encoding)
        assert str(unknown.value) == (
            f"unknown image encoding {encoding!r} (known: {', '.join(NAMED_ENCODINGS)} and "
            "{8U,8S,16U,16S,32S,32F,64F} alone or with C{1..512})"
        )


def test_channel_counts_with_leading_zeros_or_long_digit_runs_are_unknown() -> None:
    # One spelling per channel count (8UC01 would be another 8UC1 to cache), and no digit run
    # for int() to refuse with a ValueError past 4300 digits.
    for encoding in ("8UC01", "16SC001", "8UC" + "0" * 5000 + "1", "32FC" + "9" * 5000):
        with pytest.raises(UnknownEncodingError) as error:
            pixel_format(encoding)
        assert str(error.value).startswith("unknown image encoding ")
        assert len(str(error.value)) < 600  # a hostile encoding is quoted by its start only
    long_one = "8UC" + "0" * 5000 + "1"
    with pytest.raises(UnknownEncodingError) as long_error:
        pixel_format(long_one)
    assert str(long_error.value).startswith(
        f"unknown image encoding {long_one[:64]!r}… (5004 characters) (known: "
    )


def test_generic_names_for_any_channel_count() -> None:
    assert generic_encoding(np.dtype(np.uint8), 5) == "8UC5"
    assert generic_encoding(np.dtype(np.float32), 512) == "32FC512"
    assert generic_encoding(np.dtype(np.float32), 513) is None
    assert generic_encoding(np.dtype(np.uint32), 1) is None
    assert infer_encoding(np.dtype(np.uint8), 5) == "8UC5"
    assert infer_encoding(np.dtype(np.uint8), 3) == "bgr8"


def test_semi_planar_yuv_is_one_channel_of_all_buffer_rows() -> None:
    # The layout cvtColor reads; nv24's chroma rows are 2 * width bytes, cut in two rows.
    assert [(pixel_format(e).channels, pixel_format(e).rows_per_row) for e in ("nv21", "nv24")] == [
        (1, 1.5),
        (1, 3),
    ]
