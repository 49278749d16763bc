"""A large PointCloud2's CDR in one pass over its points: each chunk checked, then copied.

The general path reads a cloud's points twice and copies them twice: ``to_fields`` reads them
for ``is_dense``, then the wire codec joins them into its bytes (1.48x a memcpy for 40 MB in
``bench.natural_codecs``; 1.29x this way). Here the wire codec writes the message with empty
``data`` (``data`` and ``is_dense`` are its last fields: the length, the flag and the padding
are its last 8 bytes) and the points go, chunk by chunk, checked then copied, into a new
``bytes`` of the final size. ``WireCodec.encode`` and a ``pub`` agent's raw path
(pyconnect.ros.raw_path) take this path from ``IN_ONE_PASS_BYTES``;
tests/codecs/wire/test_point_cloud_cdr.py holds it to the general path's bytes.
"""

from __future__ import annotations

import struct
from collections.abc import Mapping
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from pyconnect.codecs.buffers import new_bytes, writable_bytes
from pyconnect.codecs.point_cloud import PointCloudCodec, copy_checking_dense_into

CLOUD = "sensor_msgs/msg/PointCloud2"


class DictWriter(Protocol):
    """What of a ``WireCodec`` the writer uses: the general path, for the fields but ``data``."""

    def from_dict(self, data: Mapping[str, Any]) -> bytes: ...


IN_ONE_PASS_BYTES = 1024 * 1024
"""From this size a PointCloud2 value's CDR is written in one pass (below, the general path)."""


def writes_in_one_pass(codec: object, value: Any) -> bool:
    """True when ``value`` is a large contiguous array and ``codec`` pyconnect's own cloud codec
    (a codec the user registered is never bypassed)."""
    return (
        type(codec) is PointCloudCodec
        and isinstance(value, np.ndarray)
        and value.flags.c_contiguous
        and value.nbytes >= IN_ONE_PASS_BYTES
    )


def cloud_cdr(wire: DictWriter, fields: dict[str, Any], points: npt.NDArray[Any]) -> bytes:
    """The CDR bytes of a PointCloud2 (``fields`` without data), ``is_dense`` set in ``fields``."""
    empty = wire.from_dict({**fields, "data": b"", "is_dense": False})
    head = len(empty) - 8
    size = points.nbytes
    end = head + 4 + size + 1
    total = end + (-end & 3)
    out = new_bytes(total)
    target = writable_bytes(out)
    target[:head] = np.frombuffer(empty, np.uint8, head)
    target[head : head + 4] = np.frombuffer(struct.pack("<I", size), np.uint8)
    dense = copy_checking_dense_into(points, target[head + 4 : head + 4 + size])
    target[end - 1] = dense
    target[end:] = 0
    fields["is_dense"] = dense
    return out
