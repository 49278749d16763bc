"""Decoded values as text for a terminal: one line with big arrays and long lists summarised."""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["format_value"]


class _Summary:
    """Stands in for a big value in echo output; its repr is the summary."""

    def __init__(self, text: str) -> None:
        self.text = text

    def __repr__(self) -> str:
        return self.text


_MAX_ITEMS = 16


def _summarise(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        if value.size <= _MAX_ITEMS and value.dtype.names is None:
            return _Summary(f"array({value.tolist()!r}, dtype={value.dtype})")
        return _Summary(f"ndarray(shape={value.shape}, dtype={value.dtype})")
    if isinstance(value, bytes | bytearray | memoryview):
        data = bytes(value)
        return data if len(data) <= _MAX_ITEMS else _Summary(f"<{len(data)} bytes>")
    if isinstance(value, dict):
        return {key: _summarise(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        items = [_summarise(item) for item in value[:_MAX_ITEMS]]
        if len(value) > _MAX_ITEMS:
            items.append(_Summary(f"... {len(value) - _MAX_ITEMS} more"))
        return tuple(items) if isinstance(value, tuple) else items
    if isinstance(value, np.generic):
        return value.item()
    return value


def format_value(value: Any) -> str:
    """One line for a decoded value, with arrays and long sequences summarised."""
    return repr(_summarise(value))
