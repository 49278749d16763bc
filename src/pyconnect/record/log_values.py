"""How a logged value becomes a file: its extension and bytes (JSON, PNG, NPY or the raw bytes,
as pyconnect.record.log_writer lists them), and writing a file so that readers see all of it
or nothing."""

from __future__ import annotations

import base64
import contextlib
import dataclasses
import io
import json
import math
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from pyconnect.codecs.stamped import Stamped
from pyconnect.errors import EncodeError, type_name_of

__all__ = [
    "RgbImage",
    "atomic_write_bytes",
    "encode_log_value",
    "finite_for_json",
    "in_native_byte_order",
    "umask_mode",
]

_IMAGE_DTYPES = (np.dtype(np.uint8), np.dtype(np.uint16))


def umask_mode(mode: int = 0o666) -> int:
    """``mode`` with the process umask applied, as ``open()`` would create a file.

    Read from /proc where it can be: setting the umask to read it back would, for a moment,
    create other threads' files with no mask at all.
    """
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return mode & ~int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    current = os.umask(0o022)
    os.umask(current)
    return mode & ~current


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` so readers see either no file or the whole file.

    The file gets the permissions ``open()`` would give it (0666 less the umask), not the
    0600 of a temporary file.
    """
    fd, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
            os.fchmod(handle.fileno(), umask_mode())
        os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        raise


def finite_for_json(value: Any) -> Any:
    """``value`` with NaN and infinities as the strings ``"nan"``, ``"inf"``, ``"-inf"``, in
    nested dicts, lists and tuples too (tuples become lists): JSON has no such numbers, and
    ``json.dumps`` would write the bare ``NaN`` that strict readers refuse."""
    if isinstance(value, float):  # numpy.float64 too: it is a float
        return value if math.isfinite(value) else str(value)
    if isinstance(value, dict):
        return {key: finite_for_json(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [finite_for_json(item) for item in value]
    return value


def _json_default(value: Any) -> Any:
    # What this returns is serialised in turn: its floats must be made finite here as well.
    return finite_for_json(_json_plain(value))


def _json_plain(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, bytes | bytearray | memoryview):
        return base64.b64encode(bytes(value)).decode("ascii")
    if isinstance(value, Stamped):
        return {"value": value.value, "stamp_ns": value.stamp_ns, "frame_id": value.frame_id}
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return dataclasses.asdict(value)
    if hasattr(value, "get_fields_and_field_types"):
        from pyconnect import codecs

        return codecs.to_dict(value)
    if isinstance(value, set | frozenset):
        return sorted(value, key=repr)
    raise TypeError(f"expected a JSON-compatible value, got {type_name_of(value)}")


@dataclasses.dataclass(frozen=True)
class RgbImage:
    """Pixels in RGB(A) order (an ``rgb8`` image): written to PNG in OpenCV's BGR(A) order."""

    pixels: np.ndarray


def in_native_byte_order(array: np.ndarray) -> np.ndarray:
    """``array`` with its items in this machine's byte order (a copy only when they are not).

    A big-endian 16-bit image (``is_bigendian``) decodes to ``>u2`` pixels, which are not
    ``uint16`` to a dtype check and which ``cv2`` does not take; a PNG file stores 16-bit
    samples big-endian whatever order they are given in, so nothing is lost.
    """
    if array.dtype.isnative:
        return array
    return array.astype(array.dtype.newbyteorder("="))


def _is_image(array: np.ndarray) -> bool:
    # Either byte order: the PNG is written from the pixels in native order.
    if array.dtype.newbyteorder("=") not in _IMAGE_DTYPES or array.size == 0:
        return False
    return array.ndim == 2 or (array.ndim == 3 and array.shape[2] in (1, 3, 4))


def encode_log_value(value: object) -> tuple[str, bytes]:
    """The file extension and bytes a logged value is written as (see the module docstring).

    Raises ``EncodeError`` for values with no file form.
    """
    if isinstance(value, Stamped):
        value = value.value
    if isinstance(value, RgbImage):
        value = value.pixels
        if _is_image(value) and value.ndim == 3 and value.shape[2] in (3, 4):
            value = value[..., [2, 1, 0, 3][: value.shape[2]]]
    if isinstance(value, np.ndarray):
        if _is_image(value):
            import cv2

            pixels = np.ascontiguousarray(in_native_byte_order(value))
            ok, encoded = cv2.imencode(".png", pixels)
            if not ok:
                raise EncodeError(f"log value: cv2 could not encode a {value.shape} PNG")
            return "png", encoded.tobytes()
        buffer = io.BytesIO()
        np.save(buffer, value, allow_pickle=False)
        return "npy", buffer.getvalue()
    if isinstance(value, bytes | bytearray | memoryview):
        return "bin", bytes(value)
    try:
        text = json.dumps(
            finite_for_json(value), default=_json_default, ensure_ascii=False, allow_nan=False
        )
    except (TypeError, ValueError) as error:
        raise EncodeError(f"log value: {error}") from None
    return "json", text.encode("utf-8")
