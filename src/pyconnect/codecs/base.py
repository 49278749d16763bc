"""What a codec is: the protocols codecs follow, the natural codecs' base; services and actions."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

from pyconnect.codecs.message_slots import field_reader
from pyconnect.errors import CodecError, CodecNotFoundError, DecodeError, type_name_of
from pyconnect.typesys.names import full_type_name


@runtime_checkable
class Codec(Protocol):
    """Turns ROS messages of one type into Python values and back.

    ``msg_type`` is the full type name (``"sensor_msgs/msg/Image"``); ``lossless`` says whether
    ``encode(decode(msg)) == msg`` holds for every message.
    """

    @property
    def msg_type(self) -> str: ...

    @property
    def lossless(self) -> bool: ...

    def encode(self, value: Any) -> Any:
        """Build a new ROS message from a Python value."""
        ...

    def decode(self, msg: Any) -> Any:
        """Turn a ROS message into a Python value."""
        ...


@runtime_checkable
class NaturalCodec(Codec, Protocol):
    """A codec whose value has fields: the one contract of the natural codecs (value ⇄ fields).

    ``to_fields(value)`` checks a natural value and gives the field dict of its message type
    (the lossless dict the generated code takes: ``{"linear": {"x": 0.2, ...}, ...}``);
    ``decode`` reads an rclpy message or a wire codec's view (both have the fields as
    attributes). The registry composes the rest: ``encode`` is the generated message code on
    ``to_fields`` (``FieldsCodec``), and the wire codec writes ``to_fields`` as CDR.
    """

    def to_fields(self, value: Any) -> Mapping[str, Any]:
        """Check a natural value; its field dict, ready for the generated code."""
        ...


class DictCodecs(Protocol):
    """What a natural codec needs of its registry: the generated dict codec of a type."""

    def lookup_dict(self, type_ref: object) -> DictCodec: ...


class FieldsCodec:
    """Base of the natural codecs: a subclass writes ``decode`` and ``to_fields``, nothing else.

    ``encode`` composes ``to_fields`` with the type's generated ``from_dict`` (fields → new
    rclpy message), found on first use through the registry that loaded the codec (or, for a
    codec made by hand, the generated code itself), so no natural codec writes a message
    twice. Hot codecs (Image, JointState, the geometry tuples) override ``encode`` with a
    direct path, said at each one.
    """

    msg_type: str
    lossless: bool
    _registry: DictCodecs | None = None
    _message_from_fields: Callable[[Mapping[str, Any]], Any] | None = None

    def to_fields(self, value: Any) -> Mapping[str, Any]:
        raise NotImplementedError

    def decode(self, msg: Any) -> Any:
        raise NotImplementedError

    def encode(self, value: Any) -> Any:
        """A new rclpy message of ``msg_type`` holding the natural value ``value``."""
        build = self._message_from_fields
        if build is None:
            build = self._bind_message_code()
        return build(self.to_fields(value))

    def use_registry(self, registry: DictCodecs) -> None:
        """Take the generated message code from ``registry`` (the registry calls this)."""
        self._registry = registry
        self._message_from_fields = None

    def _bind_message_code(self) -> Callable[[Mapping[str, Any]], Any]:
        registry = self._registry
        if registry is not None:
            build = registry.lookup_dict(self.msg_type).from_dict
        else:
            from pyconnect.codecs.type_code import (
                compiled_dict_functions,
                generated_dict_functions,
            )

            functions = generated_dict_functions(self.msg_type)
            build = (functions or compiled_dict_functions(self.msg_type)).from_dict
        self._message_from_fields = build
        return build


def message_type_name(msg: object) -> str | None:
    """The full type name a message or message class says it has, else None.

    rclpy's classes are named by their module, rosbags' and the wire codecs' views by
    ``__msgtype__`` (views of older generated code by ``msg_type``); a duck-typed stand-in
    names none.
    """
    if isinstance(msg, str):  # full_type_name would read it as a type name, not a message
        return None
    try:
        return full_type_name(msg)
    except CodecNotFoundError:
        pass
    cls = msg if isinstance(msg, type) else type(msg)
    for attribute in ("__msgtype__", "msg_type"):
        name = getattr(cls, attribute, None)
        if isinstance(name, str):
            return name
    return None


def wrong_message(msg: object, expected: str) -> DecodeError:
    """The error of a codec of ``expected`` given something else: a message of another type
    (``lookup(Image).decode(Point())``) or a message class instead of a message, which gets
    "did you mean Image()?" when it is the class of the type expected."""
    actual = message_type_name(msg)
    if isinstance(msg, type):
        name = msg.__name__
        if actual == expected or "/" not in expected:  # or any message would do
            return DecodeError(f"expected a message, got the class {name}; did you mean {name}()?")
        return DecodeError(f"expected {expected}, got the class {name}")
    return DecodeError(f"expected {expected}, got {actual or type_name_of(msg)}")


def check_message_type(msg: object, expected: str) -> None:
    """Raise ``wrong_message`` when ``msg`` is a class or names a type other than ``expected``.

    Codecs call it when a per-class cache misses, so the hot path never pays for it. An object
    that names no type passes: reading its fields decides.
    """
    if isinstance(msg, type):
        raise wrong_message(msg, expected)
    actual = message_type_name(msg)
    if actual is not None and actual != expected:
        raise wrong_message(msg, expected)


def checked_reader(msg: object, expected: str, names: tuple[str, ...]) -> Callable[[Any], Any]:
    """``message_slots.field_reader`` for the class of ``msg`` once ``check_message_type``
    passes: what a codec puts in its per-class cache."""
    check_message_type(msg, expected)
    return field_reader(type(msg), names)


def decode_failure(error: Exception, msg: object, expected: str) -> Exception:
    """What to raise when decoding ``msg`` as ``expected`` failed with ``error``.

    A message of the expected type keeps its own error (a bad field, or a bug worth seeing);
    anything else (a class, another message, a value that is no message) was the wrong input.
    Codecs call it from ``except`` only, as a ``try`` costs nothing until it raises.
    """
    if not isinstance(msg, type) and message_type_name(msg) == expected:
        return error
    return wrong_message(msg, expected)


@dataclass(frozen=True)
class DictCodec:
    """The lossless plain-dict codec of one message type, backed by generated functions."""

    msg_type: str
    msg_class: type
    to_dict: Callable[[Any], dict[str, Any]]
    from_dict: Callable[[Mapping[str, Any]], Any]
    lossless: bool = True

    def decode(self, msg: Any) -> dict[str, Any]:
        try:
            return self.to_dict(msg)
        except AttributeError:  # free until raised: lookup(X).decode(y) with y of another type
            if type(msg) is self.msg_class:
                raise
            raise wrong_message(msg, self.msg_type) from None

    def encode(self, value: Any) -> Any:
        return self.from_dict(value)


class _CompositeCodec:
    """What a service or action codec answers to the calls of a message codec.

    ``lookup`` returns a message, service or action codec; giving all three ``decode`` and
    ``encode`` keeps ``codecs.lookup(Image).decode(msg)`` type-correct for users, and tells
    whoever calls them on a service or action which part to name instead.
    """

    msg_type: str
    lossless = False

    @property
    def parts(self) -> dict[str, Codec]:
        raise NotImplementedError

    def _not_a_message(self, call: str) -> CodecError:
        kind = "service" if self.msg_type.split("/")[1] == "srv" else "action"
        parts = [part.lower() for part in self.parts]
        return CodecError(
            f"{self.msg_type} is a {kind} type: {call} one of its parts ({', '.join(parts)}), "
            f"e.g. codecs.lookup_{kind}(...).{parts[0]}.{call}(...)"
        )

    def decode(self, msg: Any) -> Any:
        raise self._not_a_message("decode")

    def encode(self, value: Any) -> Any:
        raise self._not_a_message("encode")


@dataclass(frozen=True)
class ServiceCodec(_CompositeCodec):
    """The codecs of a service's parts: ``request``, ``response`` and the Jazzy ``event``."""

    msg_type: str
    request: Codec
    response: Codec
    event: Codec | None = None

    @property
    def parts(self) -> dict[str, Codec]:
        found = {"Request": self.request, "Response": self.response}
        if self.event is not None:
            found["Event"] = self.event
        return found


@dataclass(frozen=True)
class ActionCodec(_CompositeCodec):
    """The codecs of an action's parts: ``goal``, ``result`` and ``feedback``."""

    msg_type: str
    goal: Codec
    result: Codec
    feedback: Codec

    @property
    def parts(self) -> dict[str, Codec]:
        return {"Goal": self.goal, "Result": self.result, "Feedback": self.feedback}
