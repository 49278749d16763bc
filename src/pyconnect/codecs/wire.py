"""CDR wire codecs: CDR bytes <-> natural values or lossless dicts, with no rclpy (DESIGN.md §3).

``decode(data, "sensor_msgs/msg/Image")`` turns a serialized message (``bytes``, ``bytearray``,
``memoryview`` or ``mmap``; little- or big-endian XCDR1 with its 4-byte encapsulation header)
into the natural value the registry's codec gives, or into the lossless dict. ``encode`` goes
back to little-endian CDR. Codecs come from ``generated/`` (``codecgen build``), else are
compiled on the fly from installed definitions or from a definition text (bags).

What decoding gives:

- Lossless dicts have the keys of ``pyconnect.codecs.to_dict``, but numeric arrays and
  sequences, and ``uint8``/``byte``/``char`` ones, are numpy arrays that view the input buffer
  (read-only for ``bytes``; they keep the buffer alive, and an ``mmap`` cannot close while they
  exist). ``bool`` arrays are lists of bools; strings are ``str``.
- Views (``decode_view``) are light objects with ``__slots__`` named as the ROS fields, holding
  the same values; natural codecs read them as they read rclpy messages.
- Up to 3 bytes after the message are accepted (Fast DDS pads the payload to 4 bytes; rosbags
  accepts the same), and so are the unwritten bytes up to Fast DDS's size estimate, which
  ``rclpy.serialization.serialize_message`` returns (the estimate aligns empty sequences of
  8-byte values). More, fewer or malformed bytes raise ``DecodeError`` naming the field path.
"""

from __future__ import annotations

import importlib
import threading
from collections.abc import Mapping
from typing import Any

from pyconnect.codecs.cdr_runtime import (
    HEADER_BE,
    HEADER_LE,
    ZEROS,
    Definitions,
    WireDecodeError,
    body_of,
    fastdds_estimated_size,
)
from pyconnect.codecs.field_checks import FieldError
from pyconnect.errors import CodecNotFoundError, DecodeError, EncodeError
from pyconnect.typesys.errors import DefinitionError
from pyconnect.typesys.names import parse_type_name

__all__ = [
    "WireCodec",
    "decode",
    "encode",
    "from_dict",
    "register_definition",
    "to_dict",
    "wire_codec",
]

_Functions = tuple[Any, Any, Any]


class WireCodec:
    """The CDR codec of one message type: ``decode``/``encode`` natural values, dicts, views."""

    __slots__ = ("_big", "_definitions", "_little", "_short", "msg_type", "type_hash")

    def __init__(
        self,
        msg_type: str,
        type_hash: str,
        *,
        little: _Functions,
        big: _Functions,
        definitions: Definitions,
    ) -> None:
        self.msg_type = msg_type
        self.type_hash = type_hash
        self._little = little
        self._big = big
        self._definitions = definitions
        self._short = msg_type.rsplit("/", 1)[-1]

    def __repr__(self) -> str:
        return f"WireCodec({self.msg_type!r}, type_hash={self.type_hash!r})"

    # -- decoding -----------------------------------------------------------------------------
    def _decode(self, data: Any, which: int) -> Any:
        try:
            mv, little = body_of(data)
        except DecodeError as error:  # the header's errors name the type like the others
            raise DecodeError(f"{self.msg_type}: {error}") from None
        lim = len(mv)
        try:
            value, end = (self._little if little else self._big)[which](mv, 0, lim)
        except WireDecodeError as error:
            raise DecodeError(f"{self.msg_type}{error.path}: {error.detail}") from None
        if lim - end > 3 and lim > self._estimate(value):
            raise DecodeError(
                f"{self.msg_type}: {lim - end} bytes after the end of the message "
                "(at most 3 bytes of padding may follow it)"
            )
        return value

    def _estimate(self, value: Any) -> int:
        # rclpy's serialize_message pads to Fast DDS's size estimate (see cdr_runtime).
        estimate = fastdds_estimated_size(value, self.msg_type, self._definitions)
        return (estimate + 3) & -4

    def to_dict(self, data: Any) -> dict[str, Any]:
        """The lossless dict (numeric and byte arrays as numpy views of ``data``)."""
        result: dict[str, Any] = self._decode(data, 0)
        return result

    def decode_view(self, data: Any) -> Any:
        """A light view object with attributes named as the ROS fields."""
        return self._decode(data, 1)

    def decode(self, data: Any, *, natural: bool = True, registry: Any = None) -> Any:
        """The natural value (the registry's user or natural codec on a view), else the dict."""
        if natural:
            codec = _value_codec(self.msg_type, registry)
            if codec is not None:
                return codec.decode(self._decode(data, 1))
        return self._decode(data, 0)

    # -- encoding -----------------------------------------------------------------------------
    def from_dict(self, data: Mapping[str, Any], *, big_endian: bool = False) -> bytes:
        """CDR bytes (little-endian unless ``big_endian``) of a lossless dict.

        Missing keys take the field defaults; numpy arrays and scalars are accepted; wrong
        types, out-of-range values, unknown keys and over-long sequences raise ``EncodeError``
        naming the path (``JointState.position[3]: expected float, got str``).
        """
        out: list[Any] = [HEADER_BE if big_endian else HEADER_LE]
        try:
            end = (self._big if big_endian else self._little)[2](data, out, 0)
        except FieldError as error:
            error.root = self._short
            raise
        pad = -end & 3
        if pad:
            out.append(ZEROS[pad])
        return b"".join(out)

    def encode(self, value: Any, *, registry: Any = None) -> bytes:
        """CDR bytes of a natural value (through the codec's ``to_fields``) or of a dict."""
        codec = _value_codec(self.msg_type, registry)
        if codec is not None:
            to_fields = getattr(codec, "to_fields", None)
            if to_fields is None:
                raise EncodeError(
                    f"{self.msg_type}: codec {type(codec).__name__} has no to_fields(value); "
                    "encode its lossless dict with from_dict instead"
                )
            value = to_fields(value)
        return self.from_dict(value)


_default_registry: Any = None


def _value_codec(msg_type: str, registry: Any) -> Any:
    global _default_registry  # noqa: PLW0603 (bound on first use: an import per call costs 1 us)
    if registry is None:
        registry = _default_registry
        if registry is None:
            from pyconnect.codecs.registry import default_registry

            registry = _default_registry = default_registry
    return registry.value_codec(msg_type)


# -- finding codecs ----------------------------------------------------------------------------
_lock = threading.RLock()
_by_name: dict[str, WireCodec] = {}
_by_text: dict[tuple[str, str, str], WireCodec] = {}


def _generated_module(package: str) -> Any:
    try:
        return importlib.import_module(f"pyconnect_generated.{package}.wire_codecs")
    except ModuleNotFoundError as error:
        if error.name is not None and error.name.startswith("pyconnect_generated"):
            return None
        raise


def _full_name(msg_type: str) -> str:
    parsed = parse_type_name(msg_type)
    if parsed.namespace is not None:
        return parsed.full()
    module = _generated_module(parsed.package)
    if module is not None:
        for namespace in ("msg", "srv", "action"):
            if parsed.full(namespace) in module.DEFINITIONS:
                return parsed.full(namespace)
    return parsed.full("msg")


def _from_namespace(full_name: str, namespace: Mapping[str, Any]) -> WireCodec:
    type_hash = namespace["DEFINITIONS"][full_name][0]
    little, big = namespace["LITTLE"][full_name], namespace["BIG"][full_name]
    definitions = namespace["DEFINITIONS"]
    return WireCodec(full_name, type_hash, little=little, big=big, definitions=definitions)


def _generated_codec(full_name: str) -> WireCodec | None:
    module = _generated_module(full_name.split("/", 1)[0])
    if module is None or full_name not in module.EXPORTED:
        return None
    return _from_namespace(full_name, vars(module))


def _installed_codec(full_name: str) -> WireCodec:
    try:
        from pyconnect.codecs.onthefly_wire import compile_installed
    except ImportError as error:
        raise CodecNotFoundError(
            f"{full_name}: no generated wire codec, and the generator cannot run ({error})"
        ) from None
    try:
        namespace = compile_installed(full_name.split("/", 1)[0])
    except DefinitionError as error:
        raise CodecNotFoundError(f"{full_name}: no generated wire codec and {error}") from None
    if full_name not in namespace["LITTLE"]:
        raise CodecNotFoundError(f"{full_name}: no such type in its installed package")
    return _from_namespace(full_name, namespace)


def _definition_codec(msg_type: str, text: str, encoding: str) -> WireCodec:
    from pyconnect.codecs.onthefly_wire import compile_definition, digest

    key = (msg_type, encoding, digest(text))
    cached = _by_text.get(key)
    if cached is not None:
        return cached
    try:
        msg, namespace = compile_definition(msg_type, text, encoding)
    except DefinitionError as error:
        raise CodecNotFoundError(f"{msg_type}: bad {encoding} definition: {error}") from None
    generated = _generated_codec(msg.full_name) if msg.type_hash else None
    if generated is not None and generated.type_hash == msg.type_hash:
        codec = generated  # the same type as the one generated: share its compiled code
    else:
        codec = _from_namespace(msg.full_name, namespace)
    _by_text[key] = codec
    return codec


def wire_codec(
    msg_type: str, *, definition: str | None = None, encoding: str = "ros2msg"
) -> WireCodec:
    """The wire codec of ``msg_type`` ("pkg/msg/Name" or "pkg/Name").

    Without ``definition``: the generated codec, else one compiled from the installed
    definitions (or the one ``register_definition`` made). With ``definition`` (a bag's
    ``ros2msg``/``ros2idl`` text, or ``.srv`` text for service events): compiled from that text,
    cached by the text's digest and by RIHS01 hash.
    """
    if definition is not None:
        with _lock:
            return _definition_codec(msg_type, definition, encoding)
    codec = _by_name.get(msg_type)
    if codec is not None:
        return codec
    with _lock:
        full_name = _full_name(msg_type)
        codec = _by_name.get(full_name)
        if codec is None:
            codec = _generated_codec(full_name) or _installed_codec(full_name)
            _by_name[full_name] = codec
        _by_name[msg_type] = codec
        return codec


def register_definition(msg_type: str, text: str, *, encoding: str = "ros2msg") -> WireCodec:
    """Compile ``msg_type`` from a definition text and make it the codec its name finds."""
    with _lock:
        codec = _definition_codec(msg_type, text, encoding)
        for name in {msg_type, codec.msg_type}:
            _by_name[name] = codec
        parts = codec.msg_type.split("/")
        if parts[1] == "msg":
            _by_name[f"{parts[0]}/{parts[2]}"] = codec
        return codec


def decode(data: Any, msg_type: str, *, natural: bool = True, registry: Any = None) -> Any:
    """CDR bytes -> the natural value of ``msg_type`` (or its lossless dict)."""
    return wire_codec(msg_type).decode(data, natural=natural, registry=registry)


def encode(value: Any, msg_type: str, *, registry: Any = None) -> bytes:
    """A natural value or lossless dict -> little-endian CDR bytes with the header."""
    return wire_codec(msg_type).encode(value, registry=registry)


def to_dict(data: Any, msg_type: str) -> dict[str, Any]:
    """CDR bytes -> the lossless dict of ``msg_type``."""
    return wire_codec(msg_type).to_dict(data)


def from_dict(d: Mapping[str, Any], msg_type: str) -> bytes:
    """A lossless dict -> little-endian CDR bytes with the header."""
    return wire_codec(msg_type).from_dict(d)
