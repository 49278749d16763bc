"""What a codec is: the protocol every codec follows; composite codecs of services and actions."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

from pyconnect.errors import CodecError


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


@dataclass(frozen=True)
class DictCodec:
    """The lossless plain-dict codec of one message type, backed by generated functions."""

    msg_type: str
    msg_class: type
    to_dict: Callable[[Any], dict[str, Any]]
    from_dict: Callable[[Mapping[str, Any]], Any]
    lossless: bool = True

    def decode(self, msg: Any) -> dict[str, Any]:
        return self.to_dict(msg)

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
