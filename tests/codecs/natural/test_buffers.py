"""``contiguous_bytes``: the bytes of any array in C order, padding included."""

from __future__ import annotations

import numpy as np

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
