"""``import pyconnect.transport`` without the ``zenoh`` extra: an error naming the extra."""

from __future__ import annotations

import subprocess
import sys

import pyconnect.transport

# As an install without the extra sees it: every import of zenoh (or of xxhash) fails.
IMPORT_WITHOUT = """
import sys
sys.modules[sys.argv[1]] = None
try:
    import pyconnect.transport
except ImportError as error:
    print(type(error).__name__, error.name, type(error.__cause__).__name__, sep=" | ")
    print(error)
"""


def test_the_error_names_the_distribution_and_its_extra() -> None:
    for module in ("zenoh", "xxhash"):
        done = subprocess.run(
            [sys.executable, "-c", IMPORT_WITHOUT, module],
            capture_output=True,
            text=True,
            check=True,
            timeout=120,
        )
        assert done.stdout.splitlines() == [
            f"ModuleNotFoundError | {module} | ModuleNotFoundError",
            f"pyconnect.transport needs the zenoh extra (import of {module} halted; None in "
            "sys.modules): pip install 'pyconnect-ros[zenoh]'",
        ]


def test_the_docstring_names_the_distribution() -> None:
    # `pyconnect` on the package registry is someone else's project.
    doc = pyconnect.transport.__doc__ or ""
    assert "pip install 'pyconnect-ros[zenoh]'" in doc
    assert "'pyconnect[" not in doc
