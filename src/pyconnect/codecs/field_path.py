"""Errors that collect the field path on their way up through generated code (``.header.stamp``).

One implementation of the path for both directions: ``FieldError`` (an ``EncodeError``, raised
by the dict and wire encoders and the checks they call) and ``WireDecodeError`` (a
``DecodeError``, raised by the wire decoders). Generated code calls ``within(segment)`` as the
error passes each field or index; ``root`` names the type the path starts at.
"""

from __future__ import annotations

from typing import TypeVar

from pyconnect.errors import DecodeError, EncodeError

_Error = TypeVar("_Error", bound="FieldPath")


class FieldPath:
    """The path part of a path-carrying error: ``root`` + the segments, innermost last."""

    detail: str
    segments: list[str]
    root: str

    def _start_path(self, detail: str, segment: str) -> None:
        self.detail = detail
        self.segments = [segment] if segment else []
        self.root = ""

    def within(self: _Error, segment: object) -> _Error:
        """Prefix the path with the field (``.header``) or index (``[3]``) it was raised in.

        Anything but a non-empty string (a run label of the wire decoders) adds nothing.
        """
        if segment and isinstance(segment, str):
            self.segments.append(segment)
        return self

    @property
    def path(self) -> str:
        return self.root + "".join(reversed(self.segments))

    def __str__(self) -> str:
        return f"{self.path}: {self.detail}"


def rerooted(error: EncodeError, inner: str, outer: str) -> EncodeError:
    """``error`` of a codec for type ``inner`` (its path or text starts with that type's name)
    as the error of the field ``outer`` of an enclosing type: ``Pose.orientation.z`` becomes
    ``PoseStamped.pose.orientation.z``. Anything else comes back as it is."""

    def moved(text: str) -> str | None:
        if text == inner or text.startswith((f"{inner}.", f"{inner}[", f"{inner}:")):
            return outer + text[len(inner) :]
        return None

    if isinstance(error, FieldPath) and error.segments and not error.root:
        path = moved(error.segments[-1])
        if path is not None:
            error.segments[-1] = path
        return error
    text = moved(str(error))
    if text is None or isinstance(error, FieldPath):
        return error
    return type(error)(text)


class FieldError(FieldPath, EncodeError):
    """A value does not fit its field: ``JointState.position[3]: expected float, got str``."""

    def __init__(self, segment: str, detail: str) -> None:
        super().__init__(detail)
        self._start_path(detail, segment)


class WireDecodeError(FieldPath, DecodeError):
    """CDR bytes do not decode; the wire codec prefixes the type name to the path."""

    def __init__(self, detail: str) -> None:
        super().__init__(detail)
        self._start_path(detail, "")
