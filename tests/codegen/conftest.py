"""One compiled interface package per test session (compiling takes a while), for the compile tests."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from pyconnect.codecs import search_path
from pyconnect.codegen.cli import main

DATA = Path(__file__).with_name("data")
TUTORIAL = DATA / "tutorial_interfaces"
EXTRAS = DATA / "tutorial_extras"


@pytest.fixture(scope="session")
def compiled_prefix() -> Iterator[Path]:
    """tutorial_interfaces and tutorial_extras (which depends on it), built into this environment.

    Exactly what a user does (no ``--prefix``), so a child process started with no environment
    variables at all imports them; uninstalled again at the end of the session.
    """
    # Given in reverse dependency order: the command sorts them.
    assert main(["build", "--compile", str(EXTRAS), "--compile", str(TUTORIAL)]) == 0
    search_path.refresh()
    yield Path(sys.prefix)
    assert main(["uninstall", "tutorial_extras", "tutorial_interfaces"]) == 0
