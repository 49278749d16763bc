"""``dict2str``/``str2dict``: plain data to a JSON string and back, for String topics.

JSON only, so a received string can never run code (no pickle, no eval). Tuples become lists,
numpy scalars and arrays become numbers and lists; anything else JSON cannot hold raises.
"""

from __future__ import annotations

import json
from typing import Any

from pyconnect.errors import DecodeError, EncodeError


def _plain(value: Any) -> Any:
    tolist = getattr(value, "tolist", None)
    if callable(tolist):
        return tolist()
    raise TypeError(f"expected JSON data, got {type(value).__name__}")


def dict2str(data: Any) -> str:
    """The compact JSON text of ``data`` (a dict or any JSON value)."""
    try:
        return json.dumps(data, default=_plain, separators=(",", ":"), allow_nan=True)
    except (TypeError, ValueError) as error:
        raise EncodeError(f"dict2str: {error}") from error


def str2dict(text: str) -> Any:
    """The data of a ``dict2str`` text."""
    if not isinstance(text, str | bytes | bytearray):
        raise DecodeError(f"str2dict: expected str, got {type(text).__name__}")
    try:
        return json.loads(text)
    except ValueError as error:
        raise DecodeError(f"str2dict: not JSON: {error}") from error
