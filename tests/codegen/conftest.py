"""One compiled interface package per test session (compiling takes a while), for the compile tests."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from pyconnect.codecs import search_path
from pyconnect.codegen.cli import main
from pyconnect.codegen.compile_install import InstallLayout

DATA = Path(__file__).with_name("data")
TUTORIAL = DATA / "tutorial_interfaces"
EXTRAS = DATA / "tutorial_extras"


@pytest.fixture(scope="session")
def compiled_prefix(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """tutorial_interfaces and tutorial_extras (which depends on it), built into a temp prefix.

    The prefix's site-packages is appended to ``sys.path`` for the session, as a user's
    environment would have it, so this process imports the packages and finds their codecs.
    """
    prefix = tmp_path_factory.mktemp("compiled")
    # Given in reverse dependency order: the command sorts them.
    argv = ["build", "--compile", str(EXTRAS), "--compile", str(TUTORIAL), "--prefix", str(prefix)]
    assert main(argv) == 0
    site = str(InstallLayout.for_prefix(prefix).python)
    sys.path.append(site)
    search_path.refresh()
    yield prefix
    sys.path.remove(site)
