"""What the codec registry refuses, in words: an object that cannot serve as a codec, and a
service or action named where only a message can be (its parts can)."""

from __future__ import annotations

from pyconnect.codecs.base import Codec
from pyconnect.errors import CodecNotFoundError
from pyconnect.typesys.names import is_interface_name


def codec_problem(codec: object) -> str | None:
    """Why ``codec`` cannot serve as a codec (None when it can); the text names the mistake.

    The runtime ``Codec`` protocol only asks for the attributes, which a codec class has too.
    """
    if isinstance(codec, type):
        name = codec.__name__
        return f"expected a codec instance, got the class {name}; did you mean {name}()?"
    if not isinstance(codec, Codec):
        return (
            "expected a codec with msg_type, lossless, encode and decode, "
            f"got {type(codec).__name__}"
        )
    for method in ("encode", "decode"):
        attribute = getattr(codec, method)
        if not callable(attribute):
            return (
                f"{type(codec).__name__}.{method}: expected a method, "
                f"got {type(attribute).__name__}"
            )
    return None


def interface_parts(full_name: str) -> tuple[str, list[str]] | None:
    """For a service or action type name, ("a service" or "an action", its message parts);
    None for a message."""
    _package, namespace, name = full_name.split("/")
    if namespace not in ("srv", "action") or not is_interface_name(name):
        return None
    if namespace == "srv":
        return "a service", [f"{full_name}_{part}" for part in ("Request", "Response")]
    return "an action", [f"{full_name}_{part}" for part in ("Goal", "Result", "Feedback")]


def check_wire_message(full_name: str) -> None:
    """Refuse a service or action: only messages go on the wire, a service or action as its
    parts."""
    interface = interface_parts(full_name)
    if interface is not None:
        kind, parts = interface
        raise CodecNotFoundError(
            f"{full_name} is {kind}, not a message: only its parts go on the wire "
            f"({' / '.join(parts)})"
        )
