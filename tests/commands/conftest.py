"""The plain rclpy process the live-tool tests talk to: one for this directory, ended after it
(its /chatter must not reach the tests of other directories, which share the ROS domain)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from tests.commands.processes import Lines, spawn


@pytest.fixture(scope="package")
def peer() -> Iterator[Lines]:
    process = spawn("-m", "tests.commands.plain_peer")
    lines = Lines(process)
    try:
        lines.wait_for("^ready$")
        yield lines
    finally:
        lines.stop()
