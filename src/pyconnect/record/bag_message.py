"""What a bag read yields and reports: ``BagMessage`` items and ``DecodeProblem`` entries."""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple


class _MessageFields(NamedTuple):
    topic: str
    log_time_ns: int
    value: Any


class BagMessage(_MessageFields):
    """One message: a named tuple ``(topic, log_time_ns, value)``, and its ``msg_type``."""

    msg_type: str

    def __new__(cls, topic: str, log_time_ns: int, value: Any, msg_type: str) -> BagMessage:
        message = super().__new__(cls, topic, log_time_ns, value)
        message.msg_type = msg_type
        return message

    def __repr__(self) -> str:
        return (
            f"BagMessage(topic={self.topic!r}, log_time_ns={self.log_time_ns}, "
            f"msg_type={self.msg_type!r}, value={self.value!r})"
        )

    def __reduce__(self) -> tuple[Any, ...]:
        # The reader makes a subclass per type (message_maker): pickle its items as this class.
        return (BagMessage, (self.topic, self.log_time_ns, self.value, self.msg_type))


_MESSAGE_CLASSES: dict[str, Callable[[tuple[str, int, Any]], BagMessage]] = {}


def message_maker(msg_type: str) -> Callable[[tuple[str, int, Any]], BagMessage]:
    """``make((topic, log_time_ns, value))`` -> a ``BagMessage`` of ``msg_type``.

    The reader makes one per message: a subclass holding ``msg_type`` as a class attribute
    makes them as plain tuples are made, without a per-message ``__dict__`` or ``__new__`` call.
    """
    make = _MESSAGE_CLASSES.get(msg_type)
    if make is None:
        typed = type(
            "BagMessage",
            (BagMessage,),
            {"__slots__": (), "msg_type": msg_type, "__module__": __name__},
        )
        make = _MESSAGE_CLASSES[msg_type] = functools.partial(tuple.__new__, typed)
    return make


@dataclass(frozen=True)
class DecodeProblem:
    """A message that could not be decoded: ``index`` counts the topic's messages read, from 0."""

    topic: str
    index: int
    log_time_ns: int
    reason: str

    def __str__(self) -> str:
        return f"{self.topic}[{self.index}]: {self.reason}"
