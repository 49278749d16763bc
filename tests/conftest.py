"""Test-wide set-up: every ROS test runs in its own DDS domain, on localhost only; hypothesis
never fails a test for being slow."""

from __future__ import annotations

import os

from hypothesis import HealthCheck, settings

# Nothing may depend on timing to pass: hypothesis's per-example deadline and its "too slow"
# health check fail a correct test on a loaded 2-core machine.
settings.register_profile("pyconnect", deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("pyconnect")

# Set before rclpy is imported anywhere, so no test joins another run's graph. A caller may pin
# the domain (parallel suites); otherwise the process id spreads concurrent runs apart.
os.environ.setdefault("ROS_DOMAIN_ID", str(100 + os.getpid() % 100))
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("RCUTILS_LOGGING_BUFFERED_STREAM", "1")


def require_sample_bags(path: object, present: bool) -> None:
    """Skip a module when ../shared/data/bags is missing, except in CI, where that is an error."""
    import pytest

    if present:
        return
    if os.environ.get("CI"):
        pytest.fail(f"sample bags not found at {path} (CI must have shared/ beside the repo)")
    pytest.skip(f"sample bags not found at {path}", allow_module_level=True)
