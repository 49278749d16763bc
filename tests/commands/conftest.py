"""The plain rclpy process the live-tool tests talk to, shared by the whole directory."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from tests.commands.processes import Lines, spawn


@pytest.fixture(scope="session")
def peer() -> Iterator[Lines]:
    process = spawn("-m", "tests.commands.plain_peer")
    lines = Lines(process)
    try:
        lines.wait_for("^ready$")
        yield lines
    finally:
        lines.stop()
