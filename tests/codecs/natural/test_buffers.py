"""``contiguous_bytes``: the bytes of any array in C order, padding included."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from rclpy.serialization import deserialize_message

from pyconnect import codecs
from pyconnect.codecs.buffers import contiguous_bytes

GAPPY = np.dtype(
    {"names": ["a", "b"], "formats": ["<f4", "<u2"], "offsets": [0, 8], "itemsize": 16}
)


def test_contiguous_bytes_of_strided_structured_items_keeps_their_padding() -> None:
    # np.ascontiguousarray copies fields only: the gaps came back as uninitialised memory.
    raw = np.arange(16 * 24, dtype=np.uint16).astype(np.uint8).reshape(24, 16)
    items = raw.reshape(-1).view(GAPPY)
    for view, rows in ((items[::3], raw[::3]), (items[::-1], raw[::-1])):
        assert bytes(contiguous_bytes(view)) == rows.tobytes()
    grid = items.reshape(4, 6)[:, 1::2]
    assert bytes(contiguous_bytes(grid)) == raw.reshape(4, 6, 16)[:, 1::2].tobytes()
    assert bytes(contiguous_bytes(items[:0:2])) == b""
    assert np.shares_memory(np.frombuffer(contiguous_bytes(items), np.uint8), raw)


PIXELS = np.arange(12, dtype=np.uint8).reshape(3, 4)
SUBCLASSES = [  # view(np.matrix): np.matrix() warns that the class is not recommended
    pytest.param(PIXELS.view(np.matrix), id="matrix"),
    pytest.param(PIXELS.T.copy().view(np.matrix).T, id="strided matrix"),
    pytest.param(np.ma.masked_array(PIXELS, mask=PIXELS > 5), id="masked"),
    pytest.param(PIXELS.view(np.recarray), id="recarray"),
]


@pytest.mark.parametrize("value", SUBCLASSES)
def test_contiguous_bytes_of_an_ndarray_subclass_is_its_plain_arrays(value: Any) -> None:
    # np.matrix stays 2-D through reshape(-1); a masked array's .data is an ndarray.
    view = contiguous_bytes(value)
    assert isinstance(view, memoryview) and view.ndim == 1
    assert bytes(view) == np.asarray(value).tobytes()


@pytest.mark.parametrize("value", SUBCLASSES)
def test_message_and_wire_paths_encode_an_ndarray_subclass_alike(value: Any) -> None:
    full_name = "sensor_msgs/msg/Image"
    msg = codecs.default_registry.encode(value, full_name)
    assert bytes(msg.data) == np.ascontiguousarray(value).tobytes()
    assert deserialize_message(codecs.wire.encode(value, full_name), type(msg)) == msg
