"""What the sdist and the wheel's metadata say, read from MANIFEST.in and pyproject.toml."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parent.parent
tomllib = pytest.importorskip("tomllib")  # Python 3.11+; the metadata is the same on 3.10


def _project() -> dict[str, Any]:
    table: dict[str, Any] = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    return table


def test_the_sdist_holds_the_test_suite_whole_or_not_at_all() -> None:
    # setuptools adds tests/test*.py by default: three modules without their fixtures or data.
    lines = (ROOT / "MANIFEST.in").read_text().splitlines()
    commands = [line.split() for line in lines if line.strip() and not line.startswith("#")]
    assert ["prune", "tests"] in commands
    for folder in ("bench", "examples", "tools", "docs"):
        assert ["prune", folder] in commands


def test_classifiers_match_requires_python_and_the_platform() -> None:
    project = _project()
    classifiers: list[str] = project["classifiers"]
    versions = [c.rsplit(" ", 1)[1] for c in classifiers if re.fullmatch(r".*:: 3\.\d+", c)]
    assert versions == ["3.10", "3.11", "3.12"]
    assert project["requires-python"] == ">=3.10,<3.13"
    assert "Operating System :: POSIX :: Linux" in classifiers
    # The license is the SPDX expression (PEP 639), the one LICENSE holds.
    assert project["license"] == "Apache-2.0"
    assert "Apache License" in (ROOT / "LICENSE").read_text()[:200]
    assert not [c for c in classifiers if c.startswith("License ::")]


def test_rosidls_parsers_come_with_the_base_install() -> None:
    # Bags' stored definitions are read offline and in zenoh peers, without the `ros` extra.
    names = [re.split(r"[;<>=\[ ]", d, maxsplit=1)[0] for d in _project()["dependencies"]]
    for name in (
        "ros-jazzy-rosidl-adapter",
        "ros-jazzy-rosidl-parser",
        "ros-jazzy-rosidl-generator-type-description",
    ):
        assert name in names
