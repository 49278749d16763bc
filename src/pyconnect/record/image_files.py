"""Images of a bag table as files: one lossless PNG (or ``.npy``) per image, named by its row.

``topic_table(bag, topic, images="files", image_dir=D)`` (and ``bag export --format parquet
--images files``) writes each ``sensor_msgs/Image`` of a topic through an ``ImageFiles`` and
keeps, in place of the binary ``data`` column, a ``data_path`` column of paths relative to ``D``
(for an export, ``D`` is the directory of the Parquet files, so the paths are relative to them):

- ``D/<topic>/<row>.png`` for the image of row ``<row>`` (8 digits, from 0, in log-time order;
  the topic as a directory name, ``/robot/camera`` -> ``robot__camera``); an image nested in a
  message goes to ``D/<topic>/<field path>/<row>.png``;
- PNG (written by OpenCV) holds every encoding of 8- or 16-bit unsigned pixels with 1, 3 or 4
  channels, losslessly: ``mono16`` and ``16UC1`` depth stay 16-bit; colour images are stored in
  the order PNG viewers expect (``rgb8`` pixels show as red, green, blue), so
  ``cv2.imread(path, cv2.IMREAD_UNCHANGED)`` gives the BGR(A) array OpenCV uses;
- anything PNG cannot hold losslessly (``32FC1`` depth, signed or 2-channel pixels such as
  ``yuv422``) is written with ``numpy.save`` as ``<row>.npy``, the array exactly as decoded;
- an image whose encoding is unknown, or whose ``data`` is shorter than its geometry says, is
  written as its bytes, ``<row>.bin``; the ``encoding``/``height``/``width``/``step`` columns
  beside it say how to read them.
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import numpy.typing as npt

from pyconnect.errors import PyconnectError
from pyconnect.record.log_dirs import safe_path_component

__all__ = ["IMAGE_TYPE", "PATH_COLUMN", "ImageFiles", "image_array"]

IMAGE_TYPE = "sensor_msgs/msg/Image"
PATH_COLUMN = "data_path"  # the column that replaces ``data``
_PNG_DTYPES = frozenset({np.dtype(np.uint8), np.dtype(np.uint16)})
_PNG_CHANNELS = frozenset({1, 3, 4})
_RGB_ORDER = ("rgb8", "rgba8", "rgb16", "rgba16")


def image_array(image: dict[str, Any]) -> npt.NDArray[Any]:
    """The pixels of an Image's lossless dict (row padding skipped, native byte order)."""
    from pyconnect.codecs.image import decode_image

    fields = SimpleNamespace(
        encoding=image["encoding"],
        is_bigendian=image["is_bigendian"],
        height=image["height"],
        width=image["width"],
        step=image["step"],
        data=image["data"],
    )
    array = decode_image(fields)
    if not array.dtype.isnative:
        array = array.astype(array.dtype.newbyteorder("="))
    return np.ascontiguousarray(array)


def _png_bytes(array: npt.NDArray[Any], encoding: str) -> bytes | None:
    """The PNG of ``array``, or None when PNG cannot hold its pixels losslessly."""
    channels = 1 if array.ndim == 2 else array.shape[2]
    if array.dtype not in _PNG_DTYPES or channels not in _PNG_CHANNELS or array.size == 0:
        return None
    import cv2

    if encoding in _RGB_ORDER:
        code = cv2.COLOR_RGB2BGR if channels == 3 else cv2.COLOR_RGBA2BGRA
        array = cv2.cvtColor(array, code)
    ok, encoded = cv2.imencode(".png", array)
    if not ok:  # OpenCV gives no reason; .npy is the lossless way left
        return None
    return encoded.tobytes()


class ImageFiles:
    """Writes the images of one topic's table under ``directory``; ``write`` gives the path."""

    def __init__(self, directory: str | Path, topic: str, *, folder: str | None = None) -> None:
        """``folder``: the topic's directory name under ``directory`` (default: the topic as a
        name); exports of several topics pass distinct ones (``distinct_path_components``)."""
        self.directory = Path(directory)
        self.topic_dir = Path(safe_path_component(topic) if folder is None else folder)
        self._made: set[Path] = set()

    def write(self, image: Any, row: int, field: tuple[str, ...]) -> str | None:
        """Write the image of ``row`` (its lossless dict; None: no image) and return its path
        relative to ``directory``, as POSIX text."""
        if not isinstance(image, dict) or image.get("data") is None:
            return None
        folder = self.topic_dir.joinpath(*field)
        payload: bytes | None  # None: the array goes to a .npy file
        try:
            array = image_array(image)
        except PyconnectError:
            name, payload = f"{row:08d}.bin", bytes(image["data"])
        else:
            png = _png_bytes(array, str(image["encoding"]))
            if png is not None:
                name, payload = f"{row:08d}.png", png
            else:
                name, payload = f"{row:08d}.npy", None
        target = self.directory / folder
        if target not in self._made:
            target.mkdir(parents=True, exist_ok=True)
            self._made.add(target)
        if payload is None:
            with open(target / name, "wb") as stream:
                np.save(stream, array, allow_pickle=False)
        else:
            (target / name).write_bytes(payload)
        return (folder / name).as_posix()
