"""The exception hierarchy every part of pyconnect raises (docs/design.md §5)."""

from __future__ import annotations


class PyconnectError(Exception):
    """Base of every error pyconnect raises on purpose."""


class CodecError(PyconnectError):
    """A value or message could not be converted."""


class EncodeError(CodecError, ValueError):
    """A Python value does not fit the ROS type it is encoded to.

    The message names the field path, the expected and the actual type:
    ``JointState.position[3]: expected float, got str``.
    """


class DecodeError(CodecError, ValueError):
    """A ROS message or CDR buffer cannot be turned into a value."""


class CodecNotFoundError(CodecError, LookupError):
    """No codec is known, and none can be generated, for a type name."""


class ConnectionTimeout(PyconnectError, TimeoutError):
    """Agents did not connect in time; the message names those still waiting."""


class TransportError(PyconnectError):
    """A non-ROS transport failed (TCP peers)."""


def type_name_of(value: object) -> str:
    """The short, user-facing name of a value's type, for error messages."""
    return type(value).__name__
