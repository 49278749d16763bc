"""Decode one bag topic's CDR messages with the definition stored in the bag, else the installed.

A bag's stored definition wins, because it describes the bytes as recorded (a Foxy
``sensor_msgs/Range`` has no ``variance``). Some bags store definitions that are wrong
(hand-written rosbag2 test fixtures hold ``uint8 level`` for ``rcl_interfaces/msg/Log``) or that
do not compile: those give way to the installed type, with a warning. A stored definition is
judged wrong only on evidence against the definition itself: it does not fit the bytes of the
topic's first message(s), or of several messages in a row, and the installed type decodes them.
One message that does not fit in a topic the stored definition decoded is a damaged message,
and a natural codec refusing a value the stored definition read is that value's error: both
stay errors of their message. Decoding goes through the wire codecs
(``pyconnect.codecs.wire``); no rclpy is needed.
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from pyconnect.errors import CodecError, DecodeError, PyconnectError
from pyconnect.record.bag_storage import Connection
from pyconnect.typesys.names import full_type_name

__all__ = [
    "IN_A_ROW",
    "TopicDecoder",
    "TypeMismatch",
    "installed_type_hash",
    "normalise_type_name",
    "one_line",
    "type_mismatch",
    "value_function",
]

Decode = Callable[[Any], Any]
_log = logging.getLogger("pyconnect.record")


def normalise_type_name(msg_type: str) -> str:
    """``pkg/Name`` -> ``pkg/msg/Name``; names that do not parse are kept as they are."""
    try:
        return full_type_name(msg_type)
    except CodecError:
        return msg_type


def one_line(error: BaseException) -> str:
    """An exception as one line; our own errors without their class name."""
    text = " ".join(str(error).split())
    if isinstance(error, PyconnectError):
        return text or type(error).__name__
    return f"{type(error).__name__}: {text}" if text else type(error).__name__


@dataclass(frozen=True)
class TypeMismatch:
    """A topic whose type hash in the bag differs from the installed type's."""

    topic: str
    msg_type: str
    bag_hash: str
    installed_hash: str
    bag_has_definition: bool

    def __str__(self) -> str:
        then = (
            "decoding with the definition stored in the bag"
            if self.bag_has_definition
            else "the bag stores no definition: decoding with the installed type may fail"
        )
        return (
            f"{self.topic}: {self.msg_type} in the bag ({self.bag_hash}) is not the installed "
            f"{self.msg_type} ({self.installed_hash}); {then}"
        )


@functools.lru_cache(maxsize=1024)
def installed_type_hash(msg_type: str) -> str | None:
    """The RIHS01 hash of the installed (or generated) type, None when it is not known."""
    from pyconnect.codecs import wire

    try:
        type_hash = wire.wire_codec(normalise_type_name(msg_type)).type_hash
    except Exception:  # not installed, or not compilable: nothing to compare with
        return None
    return type_hash or None


def type_mismatch(connection: Connection) -> TypeMismatch | None:
    """The mismatch when a bag's connection stores a RIHS01 hash that is not the installed
    type's (None: no hash stored, the type not installed, or the same hash)."""
    stored = connection.type_hash
    if not stored.startswith("RIHS01_"):
        return None
    installed = installed_type_hash(connection.msg_type)
    if installed is None or installed == stored:
        return None
    return TypeMismatch(
        connection.topic,
        normalise_type_name(connection.msg_type),
        stored,
        installed,
        connection.definition is not None,
    )


def _function(
    msg_type: str, definition: str | None, encoding: str, natural: bool, registry: Any
) -> tuple[Any, Decode]:
    """The wire codec and the function that decodes one message with it."""
    from pyconnect.codecs import wire

    if definition is None:
        codec = wire.wire_codec(msg_type)
    else:
        codec = wire.wire_codec(msg_type, definition=definition, encoding=encoding)
    return codec, value_function(codec, natural=natural, registry=registry)


def value_function(codec: Any, *, natural: bool, registry: Any = None) -> Decode:
    """CDR bytes -> value with ``codec``: natural (``registry``'s codec) or the lossless dict."""
    if natural and _value_codec(codec.msg_type, registry) is not None:
        if registry is None:
            decode: Decode = codec.decode
            return decode
        return functools.partial(codec.decode, registry=registry)
    # Without a user or natural codec the natural value is the lossless dict: asking the
    # registry once per topic, not once per message, is a third of the time of a bag read.
    to_dict: Decode = codec.to_dict
    return to_dict


def _value_codec(msg_type: str, registry: Any) -> Any:
    if registry is None:
        from pyconnect.codecs.registry import default_registry

        registry = default_registry
    return registry.value_codec(msg_type)


# A topic the stored definition has decoded gives way to the installed type only after this many
# messages in a row that do not fit the definition and that the installed type decodes: a single
# one is a damaged message, and switching on it would misread every intact message after it.
IN_A_ROW = 3


class TopicDecoder:
    """``decode(data)`` -> value or raises; ``recover(data, error)`` tries the installed type."""

    __slots__ = (
        "_fallback",
        "_fallback_codec",
        "_fallback_tried",
        "_fitted",
        "_row",
        "_stored_codec",
        "_stored_decode",
        "codec",
        "decode",
        "msg_type",
        "natural",
        "registry",
    )

    def __init__(
        self,
        msg_type: str,
        definition: str | None,
        encoding: str,
        *,
        natural: bool,
        registry: Any = None,
        installed_allowed: bool = True,
        type_hash: str = "",
    ) -> None:
        self.msg_type = normalise_type_name(msg_type)
        if (
            definition is not None
            and type_hash.startswith("RIHS01_")
            and installed_type_hash(self.msg_type) == type_hash
        ):
            # The stored text describes the installed type, hash for hash: its generated code
            # decodes these bytes, without compiling the text (most of a fresh process's read).
            definition = None
        self.natural = natural
        self.registry = registry
        self._fallback: Decode | None = None
        self._fallback_codec: Any = None
        # The codec of the stored definition while it decodes the topic: whether it reads a
        # message's bytes tells a damaged message or a refused value from a wrong definition.
        self._stored_codec: Any = None
        # Whether the stored definition has decoded a message of this decoder (its connection
        # and definition; not of the topic, which other connections and bags share): from then
        # on one message that does not fit it is that message's fault, not the definition's.
        self._fitted = False
        # Messages in a row that did not fit the stored definition and that the installed type
        # decoded, since the last one the definition decoded.
        self._row = 0
        self._stored_decode: Decode | None = None
        # The wire codec ``decode`` uses now (None: no codec could be built); its definitions
        # are the fields of the values (tables build their columns from them).
        self.codec: Any = None
        # A bag whose type hash differs from the installed type's is read with its own
        # definition only: the installed type would misread the bytes.
        self._fallback_tried = definition is not None and not installed_allowed
        if definition is None:
            self.decode = self._installed_or_raise()
            self._fallback_tried = True
            return
        try:
            self.codec, self.decode = _function(
                self.msg_type, definition, encoding, natural, registry
            )
        except Exception as error:  # a definition that does not compile: try the installed type
            _log.warning(
                "%s: stored definition unusable (%s); using the installed type", msg_type, error
            )
            self.decode = self._installed_or_raise(error)
            self._fallback_tried = True
            return
        self._stored_codec = self.codec
        self._stored_decode = self.decode
        self.decode = self._watch  # until the definition decodes a message

    def _watch(self, data: Any) -> Any:
        """``decode`` while there is news to note: the stored definition decoded ``data``, so it
        fits (first use), or a row of misfits ended. Then the bare decode takes over again:
        nothing is added per message once a topic reads well."""
        assert self._stored_decode is not None
        value = self._stored_decode(data)
        self._fitted, self._row = True, 0
        self.decode = self._stored_decode
        return value

    def _installed_or_raise(self, stored_error: Exception | None = None) -> Decode:
        try:
            self.codec, decode = _function(
                self.msg_type, None, "ros2msg", self.natural, self.registry
            )
        except Exception as error:
            reason = one_line(stored_error if stored_error is not None else error)
            failure = DecodeError(f"cannot build a decoder for {self.msg_type}: {reason}")

            def unavailable(data: Any) -> Any:
                raise failure

            return unavailable
        return decode

    @property
    def settled(self) -> bool:
        """Whether ``decode`` is final: no stored definition left that may give way."""
        return self._stored_codec is None or (self._fallback_tried and self._fallback is None)

    def recover(self, data: Any, error: Exception, *, topic: str = "") -> Any:
        """The value of a message the stored definition failed on (``error``), decoded with the
        installed type when the definition is at fault; else raise ``error``.

        The decoder gives way to the installed type (``decode`` and ``codec`` change) when the
        installed type decodes the message and the stored definition has decoded none of this
        decoder's messages yet, or the message is the ``IN_A_ROW``-th in a row it did not fit
        after some it did. ``topic`` names the topic in the warning that says so.
        """
        fallback = self._installed_fallback()
        if fallback is None or fallback is self.decode:
            raise error
        if self._reads_bytes(data):
            self._fitted, self._row = True, 0  # the definition fits these bytes: not its fault
            raise error
        try:
            value = fallback(data)
        except Exception:
            self._row = 0  # decoded by neither: no evidence against the definition
            raise error from None
        self._row += 1
        if self._fitted and self._row < IN_A_ROW:
            self.decode = self._watch  # the next message the definition decodes ends the row
            raise error
        fits = f"{self._row} messages in a row" if self._fitted else "its first message"
        _log.warning(
            "%sthe definition of %s stored in the bag does not fit %s (%s) and the installed "
            "type does: it decodes the rest of the topic",
            f"{topic}: " if topic else "",
            self.msg_type,
            fits,
            one_line(error),
        )
        self.decode = fallback  # the stored definition does not describe these bytes
        self.codec = self._fallback_codec
        self._stored_codec = None
        return value

    def _installed_fallback(self) -> Decode | None:
        """The installed type's decode function, built at the first need (None: none)."""
        if not self._fallback_tried:
            self._fallback_tried = True
            try:
                self._fallback_codec, self._fallback = _function(
                    self.msg_type, None, "ros2msg", self.natural, self.registry
                )
            except Exception:
                self._fallback = None
        return self._fallback

    def _reads_bytes(self, data: Any) -> bool:
        """Whether the stored definition reads ``data`` whole: then the message's error is its
        natural value's (a refused value), and no other layout may reinterpret the bytes."""
        if not self.natural or self._stored_codec is None:
            return False  # ``decode`` is the lossless read itself, which just failed
        try:
            self._stored_codec.to_dict(data)
        except Exception:
            return False
        return True
