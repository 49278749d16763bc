"""Peers for transport tests: loopback only (a free TCP port, multicast scouting off).

Every test's peers meet on their own port, so parallel runs and other workers never see each
other; the domain is the test run's ROS_DOMAIN_ID.
"""

from __future__ import annotations

import socket
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from pyconnect.transport import Peer

TIMEOUT = 30.0
"""Seconds to wait for anything that crosses zenoh: generous, so loaded machines pass."""


def wait_for(condition: Callable[[], object], timeout: float = TIMEOUT) -> bool:
    """Poll ``condition`` until it is true (discovery and delivery take a moment); False after
    ``timeout``."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


def loopback_config(*, listen: str | None = None, connect: str | None = None) -> str:
    """A JSON5 zenoh session config (what ZENOH_SESSION_CONFIG_URI names) for loopback."""
    parts = ['mode: "peer"', "scouting: { multicast: { enabled: false } }"]
    parts.append(
        f"listen: {{ endpoints: [{f'{listen!r}'.replace(chr(39), chr(34))}] }}"
        if listen
        else "listen: { endpoints: [] }"
    )
    parts.append(
        f"connect: {{ endpoints: [{f'{connect!r}'.replace(chr(39), chr(34))}] }}"
        if connect
        else "connect: { endpoints: [] }"
    )
    return "{ " + ", ".join(parts) + " }"


PeerFactory = Callable[..., Peer]


@pytest.fixture
def locator() -> str:
    return f"tcp/127.0.0.1:{free_port()}"


@pytest.fixture
def make_peer(locator: str) -> Iterator[PeerFactory]:
    """``make_peer(name, **options)``: the first peer listens on ``locator``, later ones connect."""
    peers: list[Peer] = []

    def make(name: str, **options: Any) -> Peer:
        if not peers:
            options.setdefault("listen", [locator])
            options.setdefault("connect", [])
        else:
            options.setdefault("listen", [])
            options.setdefault("connect", [locator])
        options.setdefault("handle_signals", False)
        peer = Peer(name, config=_no_scouting(), **options)
        peers.append(peer)
        return peer

    yield make
    for peer in reversed(peers):
        peer.shutdown()


def _no_scouting() -> Any:
    import zenoh

    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    return config


def zenoh_attachment(sequence: int, stamp_ns: int, gid: bytes) -> bytes:
    """rmw_zenoh's attachment as zenoh's own serializer writes it (the reference, not ours):
    int64, int64, then the GID as a sequence of 16 uint8 (rmw_zenoh's std::array)."""
    import zenoh.ext as ze

    gid_bytes = [ze.UInt8(byte) for byte in gid]
    return bytes(ze.z_serialize((ze.Int64(sequence), ze.Int64(stamp_ns), gid_bytes)).to_bytes())


def read_zenoh_attachment(data: bytes) -> tuple[int, int, bytes]:
    """(sequence, stamp ns, GID) read by zenoh's own deserializer, as rmw_zenoh reads them."""
    import zenoh
    import zenoh.ext as ze

    sequence, stamp, gid = ze.z_deserialize(
        tuple[ze.Int64, ze.Int64, list[ze.UInt8]], zenoh.ZBytes(data)
    )
    return int(sequence), int(stamp), bytes(int(byte) for byte in gid)
