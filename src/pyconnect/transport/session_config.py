"""The zenoh configuration of a peer, read the way rmw_zenoh (Jazzy) reads a session's.

rmw_zenoh ``zenoh_config.cpp``: the JSON5 file named by ``ZENOH_SESSION_CONFIG_URI`` (else its
default session config), then ``ZENOH_CONFIG_OVERRIDE='key=value;key=value'`` pairs inserted
as JSON5. Its default session config (``DEFAULT_RMW_ZENOH_SESSION_CONFIG.json5``) is a peer that
connects to a router at ``tcp/localhost:7447`` with multicast scouting off; a peer without a
file starts from the same settings, so it meets ROS nodes running ``rmw_zenoh_cpp`` through
the same router. Everything else in the file (TLS, access control, ...) passes to zenoh
unchanged. A ``zenoh.Config`` given in place of the file is copied (the caller's object is never
changed) and takes the overrides as a file does. ``connect=``/``listen=``/``mode=`` arguments
are applied last.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from pathlib import Path

import zenoh

from pyconnect.errors import TransportError

SESSION_CONFIG_ENV = "ZENOH_SESSION_CONFIG_URI"
CONFIG_OVERRIDE_ENV = "ZENOH_CONFIG_OVERRIDE"
DEFAULT_ROUTER = "tcp/localhost:7447"


def session_config(
    *,
    config: str | Path | zenoh.Config | None = None,
    connect: Sequence[str] | None = None,
    listen: Sequence[str] | None = None,
    mode: str | None = None,
) -> zenoh.Config:
    """The ``zenoh.Config`` a peer opens its session with (a new one: a ``zenoh.Config``
    given stays as it was, for the caller to use again)."""
    if isinstance(config, zenoh.Config):
        result = _copy(config)
    else:
        path = config if config is not None else os.environ.get(SESSION_CONFIG_ENV) or None
        result = _from_file(Path(path)) if path is not None else _rmw_zenoh_default()
    _apply_overrides(result, os.environ.get(CONFIG_OVERRIDE_ENV, ""))
    if mode is not None:
        _insert(result, "mode", json.dumps(mode))
    if connect is not None:
        _insert(result, "connect/endpoints", json.dumps(list(connect)))
    if listen is not None:
        _insert(result, "listen/endpoints", json.dumps(list(listen)))
    return result


def _rmw_zenoh_default() -> zenoh.Config:
    config: zenoh.Config = zenoh.Config()
    _insert(config, "mode", '"peer"')
    _insert(config, "connect/endpoints", json.dumps([DEFAULT_ROUTER]))
    _insert(config, "scouting/multicast/enabled", "false")
    return config


def _copy(config: zenoh.Config) -> zenoh.Config:
    # zenoh-python's Config cannot be copied (nor pickled); its str() is the whole
    # configuration as JSON, which from_json5 reads back.
    try:
        copied: zenoh.Config = zenoh.Config.from_json5(str(config))
        return copied
    except Exception as error:
        raise TransportError(
            f"zenoh config: cannot copy the zenoh.Config given: {error}"
        ) from error


def _from_file(path: Path) -> zenoh.Config:
    if not path.is_file():
        raise TransportError(f"zenoh config {str(path)!r}: no such file")
    try:
        config: zenoh.Config = zenoh.Config.from_file(str(path))
        return config
    except Exception as error:
        raise TransportError(f"zenoh config {str(path)!r}: {error}") from error


def _apply_overrides(config: zenoh.Config, text: str) -> None:
    for pair in text.split(";"):
        key, sep, value = pair.partition("=")
        if sep and key.strip():
            _insert(config, key.strip(), value.strip(), source=CONFIG_OVERRIDE_ENV)


def _insert(config: zenoh.Config, key: str, value: str, *, source: str = "") -> None:
    try:
        config.insert_json5(key, value)
    except Exception as error:
        where = f" (from {source})" if source else ""
        raise TransportError(f"zenoh config {key}={value}{where}: {error}") from error
