"""Codecs between ROS messages and natural Python values, found through a registry.

``lookup`` a codec by class or name, or use the module-level shortcuts that act on the
``default_registry``. This package imports without rclpy; only message classes are needed to
build messages, and the wire codecs (``pyconnect.codecs.wire``) need none.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from pyconnect.codecs.base import ActionCodec, Codec, DictCodec, ServiceCodec
from pyconnect.codecs.registry import AnyCodec, Registry, default_registry
from pyconnect.codecs.stamped import Stamped

if TYPE_CHECKING:
    from . import wire as wire

__all__ = [
    "ActionCodec",
    "AnyCodec",
    "Codec",
    "CvBridgeError",
    "DictCodec",
    "Registry",
    "ServiceCodec",
    "Stamped",
    "cv2_to_imgmsg",
    "decode",
    "default_registry",
    "encode",
    "from_dict",
    "imgmsg_to_cv2",
    "lookup",
    "lookup_action",
    "lookup_service",
    "register",
    "to_dict",
    "unregister",
    "wire",
]


def lookup(type_ref: object) -> AnyCodec:
    """The codec of a class, ``"pkg/msg/Name"`` or ``"pkg/Name"`` in the default registry.

    Every codec it returns has ``decode``/``encode``; for the parts of a service or action
    type, ``lookup_service``/``lookup_action`` give them typed.
    """
    return default_registry.lookup(type_ref)


def lookup_service(type_ref: object) -> ServiceCodec:
    """The part codecs of a service type: ``lookup_service(SetBool).request.encode(...)``."""
    return default_registry.lookup_service(type_ref)


def lookup_action(type_ref: object) -> ActionCodec:
    """The part codecs of an action type: ``lookup_action(Fibonacci).goal.encode(...)``."""
    return default_registry.lookup_action(type_ref)


def decode(msg: Any, *, stamped: bool = False) -> Any:
    """Decode a ROS message to its natural value (``stamped=True`` gives a ``Stamped``)."""
    return default_registry.decode(msg, stamped=stamped)


def encode(value: Any, type_ref: object) -> Any:
    """Encode a natural value (or a ``Stamped``) to a new message of ``type_ref``."""
    return default_registry.encode(value, type_ref)


def to_dict(msg: Any) -> dict[str, Any]:
    """The lossless plain dict of any message."""
    return default_registry.to_dict(msg)


def from_dict(data: Mapping[str, Any], type_ref: object) -> Any:
    """A new message of ``type_ref`` from a plain dict; missing keys take the defaults."""
    return default_registry.from_dict(data, type_ref)


def register(type_ref: object, codec: Codec, *, override: bool = False) -> None:
    """Register a user codec in the default registry; user codecs win over built-in ones."""
    default_registry.register(type_ref, codec, override=override)


def unregister(type_ref: object) -> None:
    """Remove a user codec from the default registry."""
    default_registry.unregister(type_ref)


def __getattr__(name: str) -> Any:
    # `codecs.wire` is imported on first use so that plain lookups stay light.
    if name == "wire":
        import importlib

        return importlib.import_module("pyconnect.codecs.wire")
    if name == "CvBridgeError":
        from pyconnect.codecs.cv_bridge_calls import CvBridgeError

        return CvBridgeError
    raise AttributeError(f"module 'pyconnect.codecs' has no attribute {name!r}")


def imgmsg_to_cv2(msg: Any, desired_encoding: str = "passthrough") -> Any:
    """cv_bridge's call: an Image message's pixels as a writable OpenCV array."""
    from pyconnect.codecs.cv_bridge_calls import imgmsg_to_cv2 as convert_message

    return convert_message(msg, desired_encoding)


def cv2_to_imgmsg(cvim: Any, encoding: str = "passthrough", header: Any | None = None) -> Any:
    """cv_bridge's call: a new Image message from an OpenCV array (one copy)."""
    from pyconnect.codecs.cv_bridge_calls import cv2_to_imgmsg as convert_array

    return convert_array(cvim, encoding, header)
