"""A zenoh router started from Python (for tests and small set-ups; ``zenohd`` is the usual one).

``start_router(listen=['tcp/0.0.0.0:7447'])`` opens a session in router mode: peers that
``connect`` to it find each other through it (zenoh's gossip), as ROS nodes running
``rmw_zenoh_cpp`` find each other through ``rmw_zenohd``. ``python -m pyconnect.transport.router
tcp/0.0.0.0:7447`` runs one until Ctrl-C (``--config FILE`` for TLS or access control).
"""

# zenoh's stubs leave undeclare() and close() unannotated.
# mypy: disable-error-code="no-untyped-call"

from __future__ import annotations

import argparse
import json
import signal
import sys
import threading
from collections.abc import Sequence
from pathlib import Path

import zenoh

from pyconnect.errors import TransportError

DEFAULT_LISTEN = "tcp/0.0.0.0:7447"


def start_router(
    *,
    listen: Sequence[str] | None = None,
    config: str | Path | None = None,
    multicast_scouting: bool = False,
) -> zenoh.Session:
    """An open router session; ``close()`` stops it. ``config`` is a JSON5 file (TLS, ACL...);
    ``listen`` replaces its listen endpoints (default: the file's, else ``tcp/0.0.0.0:7447``)."""
    where = ", ".join(listen) if listen else str(config or DEFAULT_LISTEN)
    try:
        zenoh_config = zenoh.Config.from_file(str(config)) if config else zenoh.Config()
        zenoh_config.insert_json5("mode", '"router"')
        if listen or not config:
            endpoints = list(listen) if listen else [DEFAULT_LISTEN]
            zenoh_config.insert_json5("listen/endpoints", json.dumps(endpoints))
        zenoh_config.insert_json5(
            "scouting/multicast/enabled", "true" if multicast_scouting else "false"
        )
        return zenoh.open(zenoh_config)
    except Exception as error:
        raise TransportError(f"zenoh router on {where}: {error}") from error


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m pyconnect.transport.router [ENDPOINT ...] [--config FILE]``: run a router
    until Ctrl-C or SIGTERM (exit 0); an endpoint it cannot listen on is one line, exit 1."""
    parser = argparse.ArgumentParser(
        prog="python -m pyconnect.transport.router",
        description="Run a zenoh router until Ctrl-C (peers connect to it: tcp/HOST:7447).",
    )
    parser.add_argument(
        "endpoints", nargs="*", metavar="ENDPOINT",
        help=f"where to listen (default: the --config file's, else {DEFAULT_LISTEN})",
    )  # fmt: skip
    parser.add_argument("--config", type=Path, help="a zenoh JSON5 config file (TLS, ACL...)")
    options = parser.parse_args(argv)
    try:
        router = start_router(listen=options.endpoints, config=options.config)
    except TransportError as error:
        print(f"router: {' '.join(str(error).split())}", file=sys.stderr)
        return 1
    if options.endpoints:
        listening = ", ".join(options.endpoints)
    else:
        listening = f"the endpoints of {options.config}" if options.config else DEFAULT_LISTEN
    print(f"zenoh router {router.zid()} listening on {listening}", flush=True)
    stop = threading.Event()
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda _signum, _frame: stop.set())
    while not stop.wait(0.5):
        pass
    router.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
