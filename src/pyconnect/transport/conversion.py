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

from pyconnect.codecs.fast_paths import fast_paths
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

    The value codec is looked up once, when the agent is made (as ``CustomNode`` does), and
    ``encode``/``decode`` are closures over the functions that path needs: per message nothing
    is looked up or tested but the value (bench/transport.py measures it). The smallest std_msgs
    types (String, Int*, Float*) take the straight-line paths of ``fast_paths``.
    """

    encode: Callable[[Any], bytes]
    decode: Callable[[bytes], Any]

    def __init__(
        self,
        *,
        describe: str,
        codec: WireCodec,
        registry: Any,
        encode_func: EncodeFunc | None = None,
        decode_func: DecodeFunc | None = None,
        raw: bool = False,
        fast: bool = True,
    ) -> None:
        self.describe = describe
        self.codec = codec
        self.registry = registry
        self.raw = raw
        value_codec = registry.value_codec(codec.msg_type)
        fields_codec = registry.fields_codec(codec.msg_type)
        to_fields = fields_codec.to_fields if fields_codec is not None else None
        if raw:
            self.encode, self.decode = self._raw_encode, _same
            return
        self.encode = self._encoder(
            encode_func,
            to_fields,
            # A value codec without to_fields: the wire codec's encode says why it cannot.
            codec_encodes=value_codec is not None and to_fields is None,
        )
        self.decode = self._decoder(
            decode_func, value_codec.decode if value_codec is not None else None
        )
        if fast and encode_func is None and decode_func is None:
            paths = fast_paths(value_codec, general_encode=self.encode, general_decode=self.decode)
            if paths is not None:
                self.encode, self.decode = paths

    def _raw_encode(self, value: Any) -> bytes:
        if not isinstance(value, (bytes, bytearray, memoryview)):
            raise EncodeError(f"{self.describe}: expected CDR bytes, got {type(value).__name__}")
        return bytes(value)

    def _encoder(
        self,
        encode_func: EncodeFunc | None,
        to_fields: Callable[[Any], Any] | None,
        *,
        codec_encodes: bool,
    ) -> Callable[[Any], bytes]:
        codec, registry, describe = self.codec, self.registry, self.describe
        from_dict = codec.from_dict
        where = "encode_func" if encode_func is not None else "codec"

        def convert(value: Any) -> bytes:
            if encode_func is not None:
                default = _as_fields(codec.to_dict(from_dict({})))
                return from_dict(_as_dict(encode_func(value, default)))
            if value is None:
                return from_dict({})  # send() without data: the default message
            if to_fields is not None:
                return from_dict(to_fields(value))
            if codec_encodes:
                return codec.encode(value, registry=registry)
            return from_dict(value)

        def encode(value: Any) -> bytes:
            try:
                if to_fields is not None and encode_func is None and value is not None:
                    return from_dict(to_fields(value))  # the common case, first
                return convert(value)
            except CodecError as error:
                if str(error).startswith(describe):
                    raise
                raise EncodeError(f"{describe}: {error}") from error
            except Exception as error:
                raise EncodeError(
                    f"{describe}: {where} raised {type(error).__name__}: {error}"
                ) from error

        return encode

    def _decoder(
        self, decode_func: DecodeFunc | None, value_decode: Callable[[Any], Any] | None
    ) -> Callable[[bytes], Any]:
        describe, decode_view = self.describe, self.codec.decode_view
        convert = decode_func or value_decode
        where = "decode_func" if decode_func is not None else "codec"
        to_dict = self.codec.to_dict

        def decode(payload: bytes) -> Any:
            try:
                if convert is not None:
                    return convert(decode_view(payload))
                return to_dict(payload)
            except CodecError as error:
                raise DecodeError(f"{describe}: {error}") from error
            except Exception as error:
                raise DecodeError(
                    f"{describe}: {where} raised {type(error).__name__}: {error}"
                ) from error

        return decode


def _same(payload: bytes) -> bytes:
    return payload
