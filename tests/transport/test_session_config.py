"""How peers find each other: config files as rmw_zenoh reads them, overrides, a router."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from pyconnect.errors import TransportError
from pyconnect.transport import Peer, start_router
from tests.transport.conftest import free_port, loopback_config

TIMEOUT = 30.0


def exchange(sender: Peer, receiver: Peer) -> str:
    got = threading.Event()
    sub = receiver.add_agent(
        conn_name="chatter",
        conn_type="sub",
        data_interface="std_msgs/msg/String",
        response_func=lambda _v: got.set(),
    )
    pub = sender.add_agent(
        conn_name="chatter", conn_type="pub", data_interface="std_msgs/msg/String"
    )
    deadline = time.monotonic() + TIMEOUT
    assert sender.wait_for_graph(lambda: pub.subscriber_count == 1, deadline)
    pub.send("hello")
    assert got.wait(TIMEOUT)
    value: str = sub.get()
    return value


def test_the_session_config_env_var_and_override(
    locator: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    config = tmp_path / "session.json5"
    config.write_text(loopback_config(listen=locator))
    monkeypatch.setenv("ZENOH_SESSION_CONFIG_URI", str(config))
    monkeypatch.setenv("ZENOH_CONFIG_OVERRIDE", "")
    with Peer("listener", handle_signals=False) as first:
        # The second reads the same file, but the override makes it connect instead of listen.
        monkeypatch.setenv(
            "ZENOH_CONFIG_OVERRIDE", f'listen/endpoints=[];connect/endpoints=["{locator}"]'
        )
        with Peer("talker", handle_signals=False) as second:
            assert exchange(second, first) == "hello"
            assert first.domain_id == int(os.environ["ROS_DOMAIN_ID"])


def test_two_peers_meet_through_a_router_started_from_python() -> None:
    router_locator = f"tcp/127.0.0.1:{free_port()}"
    router = start_router(listen=[router_locator])
    try:
        options = {
            "connect": [router_locator],
            "listen": ["tcp/127.0.0.1:0"],
            "handle_signals": False,
        }
        with (
            Peer("a", config=_peer_config(), **options) as a,
            Peer("b", config=_peer_config(), **options) as b,
        ):
            assert exchange(a, b) == "hello"
            assert {"a", "b"} <= set(a.node_names())
    finally:
        router.close()


def _peer_config() -> object:
    import zenoh

    config = zenoh.Config()
    config.insert_json5("scouting/multicast/enabled", "false")
    return config


def test_a_missing_config_file_raises_transport_error(tmp_path: Path) -> None:
    missing = tmp_path / "nope.json5"
    with pytest.raises(TransportError) as raised:
        Peer("x", config=missing, handle_signals=False)
    assert str(raised.value) == f"zenoh config {str(missing)!r}: no such file"


def test_a_bad_override_raises_transport_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("ZENOH_CONFIG_OVERRIDE", "mode=[")
    with pytest.raises(TransportError) as raised:
        Peer("x", handle_signals=False)
    assert str(raised.value).startswith("zenoh config mode=[ (from ZENOH_CONFIG_OVERRIDE): ")


def test_an_unusable_listen_locator_raises_transport_error() -> None:
    with pytest.raises(TransportError) as raised:
        Peer("x", config=_peer_config(), listen=["tcp/203.0.113.1:7447"], handle_signals=False)  # type: ignore[arg-type]
    assert str(raised.value).startswith("peer 'x': cannot open a zenoh session: ")


def test_tls_and_access_control_settings_pass_through(tmp_path: Path) -> None:
    config = tmp_path / "secure.json5"
    config.write_text(
        "{ mode: 'peer', scouting: { multicast: { enabled: false } },"
        " listen: { endpoints: [] }, connect: { endpoints: [] },"
        " access_control: { enabled: true, default_permission: 'allow',"
        " rules: [], subjects: [], policies: [] },"
        " transport: { link: { tls: { root_ca_certificate: '/etc/robot/ca.pem' } } } }"
    )
    with Peer("secure", config=config, handle_signals=False) as peer:
        get = peer.config.get_json  # JSON text of the setting
        assert json.loads(get("access_control/enabled")) is True
        assert json.loads(get("access_control/default_permission")) == "allow"
        assert json.loads(get("transport/link/tls/root_ca_certificate")) == "/etc/robot/ca.pem"


def test_the_router_module_runs_until_sigint_and_exits_0() -> None:
    """README: ``python -m pyconnect.transport.router ENDPOINT`` runs a router (peers meet
    through it) until Ctrl-C, which ends it with exit status 0 and no warning on stderr."""
    router_locator = f"tcp/127.0.0.1:{free_port()}"
    router = subprocess.Popen(
        [sys.executable, "-m", "pyconnect.transport.router", router_locator],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        # Ready when two peers that connect to it exchange a message through it.
        options = {
            "connect": [router_locator],
            "listen": ["tcp/127.0.0.1:0"],
            "handle_signals": False,
        }
        with (
            Peer("a", config=_peer_config(), **options) as a,  # type: ignore[arg-type]
            Peer("b", config=_peer_config(), **options) as b,  # type: ignore[arg-type]
        ):
            assert exchange(a, b) == "hello"
        assert router.stdout is not None
        assert router.stdout.readline().startswith("zenoh router ")
        # It prints that line just before it installs its handlers: wait for those (its SIGTERM
        # handler is the last), or a SIGINT sent in between would end it with a traceback.
        assert _catches_sigterm(router.pid)
        router.send_signal(signal.SIGINT)
        _out, err = router.communicate(timeout=TIMEOUT)
    finally:
        if router.poll() is None:
            router.kill()
            router.communicate()
    assert router.returncode == 0, err
    assert "RuntimeWarning" not in err, err


def _catches_sigterm(pid: int) -> bool:
    """True once process ``pid`` has a SIGTERM handler (Linux: SigCgt in /proc/<pid>/status)."""
    waited = threading.Event()
    for _ in range(int(TIMEOUT / 0.01)):
        status = Path(f"/proc/{pid}/status").read_text()
        caught = int(status.split("SigCgt:")[1].split()[0], 16)
        if caught & (1 << (signal.SIGTERM - 1)):
            return True
        waited.wait(0.01)
    return False


def test_a_peer_without_a_config_file_starts_from_rmw_zenohs_default(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """README (Many machines): without a file a peer starts from rmw_zenoh's default session
    config: a peer that connects to a router on tcp/localhost:7447, multicast scouting off.
    (Nothing need listen on 7447: a peer keeps trying in the background.)"""
    monkeypatch.delenv("ZENOH_SESSION_CONFIG_URI", raising=False)
    monkeypatch.delenv("ZENOH_CONFIG_OVERRIDE", raising=False)
    with Peer("plain", handle_signals=False) as peer:
        get = peer.config.get_json  # JSON text of the setting
        assert json.loads(get("mode")) == "peer"
        assert json.loads(get("connect/endpoints")) == ["tcp/localhost:7447"]
        assert json.loads(get("scouting/multicast/enabled")) is False


def test_a_zenoh_config_given_is_copied_and_takes_the_overrides(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """listen= inserted into the caller's Config, and the override was silently not applied."""
    import zenoh

    from pyconnect.transport.session_config import session_config

    given = zenoh.Config()
    given.insert_json5("mode", '"peer"')
    given.insert_json5("listen/endpoints", "[]")
    before = str(given)
    monkeypatch.setenv("ZENOH_CONFIG_OVERRIDE", 'mode="client"')
    used = session_config(config=given, listen=["tcp/127.0.0.1:27605"])
    assert str(given) == before
    assert json.loads(used.get_json("mode")) == "client"
    assert json.loads(used.get_json("listen/endpoints")) == ["tcp/127.0.0.1:27605"]
    assert json.loads(given.get_json("listen/endpoints")) == []
