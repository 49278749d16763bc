"""How a peer's agent turns values into CDR bytes and back: the user's functions or the codecs.

Without rclpy there are no message classes, so the seed signatures get stand-ins:
``decode_func(msg)`` receives the wire codec's read-only view (attributes named as the ROS
fields, as on an rclpy message); ``encode_func(data, msg)`` receives a ``MessageFields`` of
the type's default values, sets attributes on it and returns it (or a lossless dict). Without
them the registry's codec gives the natural value (an Image is an ndarray, a JointState a
dict). ``raw=True`` passes CDR bytes through untouched (the ROS bridge uses it).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from types import SimpleNamespace
from typing import Any

from pyconnect.codecs.wire import WireCodec
from pyconnect.errors import CodecError, DecodeError, EncodeError

EncodeFunc = Callable[[Any, Any], Any]
DecodeFunc = Callable[[Any], Any]


class MessageFields(SimpleNamespace):
    """A mutable message without rclpy: attributes named as the fields, defaults filled in."""


def _as_fields(value: Any) -> Any:
    if isinstance(value, Mapping):
        return MessageFields(**{key: _as_fields(item) for key, item in value.items()})
    if isinstance(value, list):
        return [_as_fields(item) for item in value]
    return value


def _as_dict(value: Any) -> Any:
    if isinstance(value, SimpleNamespace):
        value = vars(value)
    if isinstance(value, Mapping):
        return {key: _as_dict(item) for key, item in value.items()}
    if isinstance(value, list):
        return [_as_dict(item) for item in value]
    return value


class WireConversion:
    """Encode values to CDR bytes and decode CDR bytes to values, for one type and agent.

    The value codec is looked up once, when the agent is made (as ``CustomNode`` does), so the
    per-message path is the codec's own functions and nothing else (bench/transport.py).
    """

    def __init__(
        self,
        *,
        describe: str,
        codec: WireCodec,
        registry: Any,
        encode_func: EncodeFunc | None = None,
        decode_func: DecodeFunc | None = None,
        raw: bool = False,
    ) -> None:
        self.describe = describe
        self.codec = codec
        self.registry = registry
        self.raw = raw
        self._encode_func = encode_func
        self._decode_func = decode_func
        value_codec = registry.value_codec(codec.msg_type)
        fields_codec = registry.fields_codec(codec.msg_type)
        self._to_fields: Callable[[Any], Any] | None = (
            fields_codec.to_fields if fields_codec is not None else None
        )
        self._value_decode: Callable[[Any], Any] | None = (
            value_codec.decode if value_codec is not None else None
        )
        # A value codec without to_fields: the wire codec's encode says why it cannot encode.
        self._codec_encodes = value_codec is not None and self._to_fields is None

    def encode(self, value: Any) -> bytes:
        if self.raw:
            if not isinstance(value, (bytes, bytearray, memoryview)):
                raise EncodeError(
                    f"{self.describe}: expected CDR bytes, got {type(value).__name__}"
                )
            return bytes(value)
        try:
            if self._encode_func is not None:
                default = _as_fields(self.codec.to_dict(self.codec.from_dict({})))
                return self.codec.from_dict(_as_dict(self._encode_func(value, default)))
            if value is None:
                return self.codec.from_dict({})  # send() without data: the default message
            to_fields = self._to_fields
            if to_fields is not None:
                return self.codec.from_dict(to_fields(value))
            if self._codec_encodes:
                return self.codec.encode(value, registry=self.registry)
            return self.codec.from_dict(value)
        except CodecError as error:
            if str(error).startswith(self.describe):
                raise
            raise EncodeError(f"{self.describe}: {error}") from error
        except Exception as error:
            where = "encode_func" if self._encode_func is not None else "codec"
            raise EncodeError(
                f"{self.describe}: {where} raised {type(error).__name__}: {error}"
            ) from error

    def decode(self, payload: bytes) -> Any:
        if self.raw:
            return payload
        try:
            if self._decode_func is not None:
                return self._decode_func(self.codec.decode_view(payload))
            value_decode = self._value_decode
            if value_decode is not None:
                return value_decode(self.codec.decode_view(payload))
            return self.codec.to_dict(payload)
        except CodecError as error:
            raise DecodeError(f"{self.describe}: {error}") from error
        except Exception as error:
            where = "decode_func" if self._decode_func is not None else "codec"
            raise DecodeError(
                f"{self.describe}: {where} raised {type(error).__name__}: {error}"
            ) from error
