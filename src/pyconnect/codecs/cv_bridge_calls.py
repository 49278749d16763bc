"""cv_bridge's two calls, ``imgmsg_to_cv2`` and ``cv2_to_imgmsg``, for code that migrates.

They keep cv_bridge's (ROS 2, ``vision_opencv``) names, defaults and rules: ``"passthrough"``
keeps the message's encoding, and an image encoded with ``passthrough`` gets the OpenCV type
name (``8UC3``) as its encoding; an explicit encoding must match the array's type
(``encoding specified as bgr8, but image has incompatible type 8UC1``); failures raise
``CvBridgeError``, a ``TypeError`` as in cv_bridge. Unlike cv_bridge they work with numpy 2
(vision_opencv#535), honour row padding and byte order, and always return a writable array in
native byte order (a view of a live message's buffer, or one copy where that buffer is
read-only, e.g. a message read from a bag).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from pyconnect.codecs.image import decode_image, encode_image
from pyconnect.codecs.image_convert import convert
from pyconnect.codecs.image_encodings import (
    UnknownEncodingError,
    generic_encoding,
    pixel_format,
)
from pyconnect.errors import CodecError, type_name_of

__all__ = ["CvBridgeError", "cv2_to_imgmsg", "imgmsg_to_cv2"]


class CvBridgeError(CodecError, TypeError):
    """An image and a message (or two encodings) do not fit; cv_bridge's error, a TypeError."""


def imgmsg_to_cv2(msg: Any, desired_encoding: str = "passthrough") -> npt.NDArray[Any]:
    """The pixels of a ``sensor_msgs/Image`` as an OpenCV array in ``desired_encoding``."""
    try:
        image = decode_image(msg)
        if not image.dtype.isnative:
            image = image.astype(image.dtype.newbyteorder("="))
        image = convert(image, desired_encoding, source_encoding=msg.encoding)
    except CodecError as error:
        raise CvBridgeError(str(error)) from None
    if not image.flags.writeable:
        image = np.array(image)
    return image


def cv2_to_imgmsg(cvim: Any, encoding: str = "passthrough", header: Any | None = None) -> Any:
    """A new ``sensor_msgs/Image`` holding ``cvim`` (one copy), with ``header`` when given."""
    if not isinstance(cvim, np.ndarray) or cvim.ndim not in (2, 3):
        raise TypeError(
            f"Your input type is not a numpy array of shape (H, W) or (H, W, C), "
            f"got {type_name_of(cvim)}"
        )
    channels = 1 if cvim.ndim == 2 else cvim.shape[2]
    cv_type = generic_encoding(cvim.dtype, channels)
    if cv_type is None:
        raise CvBridgeError(f"cv2_to_imgmsg: no OpenCV type for {cvim.dtype.name} x {channels}")
    if encoding == "passthrough":
        encoding = cv_type
    else:
        try:
            wanted = pixel_format(encoding)
        except UnknownEncodingError as error:
            raise CvBridgeError(str(error)) from None
        if generic_encoding(wanted.dtype, wanted.channels) != cv_type:
            raise CvBridgeError(
                f"encoding specified as {encoding}, but image has incompatible type {cv_type}"
            )
    try:
        msg = encode_image(cvim, encoding=encoding)
    except CodecError as error:
        raise CvBridgeError(str(error)) from None
    if header is not None:
        msg.header = header
    return msg
