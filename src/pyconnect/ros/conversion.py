"""How an agent turns values into messages and back: the user's functions, or the registry codec.

``encode_func(data, msg) -> msg`` and ``decode_func(msg) -> data`` keep the seed signatures and
replace the codec for that agent only. A value that already is a message of the right type is
sent as it is; ``None`` (or ``send()`` with no argument) is the message of a type without
fields. Every failure becomes an ``EncodeError``/``DecodeError`` naming the agent.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from pyconnect.codecs.base import Codec
from pyconnect.codecs.stamped import Stamped, encode_stamped
from pyconnect.errors import CodecError, DecodeError, EncodeError, PyconnectError
from pyconnect.ros.interfaces import header_field, interface_name

EncodeFunc = Callable[[Any, Any], Any]
DecodeFunc = Callable[[Any], Any]


class MessageConversion:
    """Encode and decode one message type for one agent."""

    def __init__(
        self,
        *,
        describe: str,
        msg_class: type,
        codec_of: Callable[[], Codec] | None,
        encode_func: EncodeFunc | None = None,
        decode_func: DecodeFunc | None = None,
    ) -> None:
        self.describe = describe
        self.msg_class = msg_class
        self.msg_type = interface_name(msg_class)
        self.has_header = header_field(msg_class)
        self.is_empty = not msg_class.get_fields_and_field_types()  # type: ignore[attr-defined]
        """A type without fields (``Trigger`` and ``GetMap`` requests): ``None`` encodes it."""
        self._codec_of = codec_of
        self._codec: Codec | None = None
        self._encode_func = encode_func
        self._decode_func = decode_func
        if decode_func is not None:
            self.decode = decode_func  # type: ignore[method-assign,assignment]  # fast path

    @property
    def codec(self) -> Codec:
        """The registry codec, looked up on first use (so user functions need no codec)."""
        if self._codec is None:
            if self._codec_of is None:
                raise PyconnectError(f"{self.describe}: no codec for {self.msg_type}")
            try:
                self._codec = self._codec_of()
            except PyconnectError as error:
                raise type(error)(f"{self.describe}: {error}") from error
        return self._codec

    def prepare(self) -> None:
        """Look the codec up now (when no user function replaces it), to fail at creation."""
        if self._encode_func is None or self._decode_func is None:
            _ = self.codec

    def decode(self, msg: Any) -> Any:
        """The value of a received message."""
        return self.codec.decode(msg)

    def decode_checked(self, msg: Any) -> Any:
        """``decode`` with any failure turned into a ``DecodeError`` naming the agent."""
        try:
            return self.decode(msg)
        except PyconnectError as error:
            raise DecodeError(f"{self.describe}: {error}") from error
        except Exception as error:
            where = "decode_func" if self._decode_func is not None else "codec"
            raise DecodeError(
                f"{self.describe}: {where} raised {type(error).__name__}: {error}"
            ) from error

    def encode(self, value: Any) -> tuple[Any, bool]:
        """A new message for ``value``, and whether the caller set its header (``Stamped``)."""
        try:
            if self._encode_func is not None:
                msg = self._encode_func(value, self.msg_class())
                if not isinstance(msg, self.msg_class):
                    raise EncodeError(
                        f"encode_func returned {type(msg).__name__}, expected {self.msg_type}"
                    )
                return msg, False
            if isinstance(value, self.msg_class):
                return value, False
            if value is None and self.is_empty:
                return self.msg_class(), False
            stamped = isinstance(value, Stamped)
            msg = encode_stamped(self.codec, value) if stamped else self.codec.encode(value)
            # A codec that builds another class would fail in rclpy naming neither the agent
            # nor the codec (a service server would never answer); one identity test here.
            if type(msg) is not self.msg_class and not isinstance(msg, self.msg_class):
                raise self._wrong_class(msg)
            return msg, stamped
        except CodecError as error:
            if str(error).startswith(self.describe):
                raise
            raise EncodeError(f"{self.describe}: {error}") from error
        except PyconnectError:
            raise
        except Exception as error:
            where = "encode_func" if self._encode_func is not None else "codec"
            raise EncodeError(
                f"{self.describe}: {where} raised {type(error).__name__} for "
                f"{_short_repr(value)}: {error}"
            ) from error

    def _wrong_class(self, msg: Any) -> EncodeError:
        return EncodeError(
            f"codec {type(self.codec).__name__}.encode returned {type(msg).__name__}, "
            f"expected {self.msg_type}"
        )


def _short_repr(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
