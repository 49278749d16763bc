"""``codecgen build``/``check`` default to the folder pyconnect loads its codecs from."""

from __future__ import annotations

import importlib.machinery
import importlib.util
from pathlib import Path
from typing import Any

import pytest

from pyconnect.codegen import build
from pyconnect.codegen.build import default_out_dir


def test_a_checkout_builds_into_its_generated_folder() -> None:
    assert default_out_dir() == Path(__file__).resolve().parents[2] / "generated"


def test_an_installed_wheel_builds_beside_its_installed_codecs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A wheel puts pyconnect_generated in site-packages; the checkout's generated/ folder
    # (three levels above the module) is then a folder nothing reads: build wrote there and
    # check reported every installed file stale.
    site = tmp_path / "lib" / "python3.11" / "site-packages"
    origin = site / "pyconnect_generated" / "__init__.py"

    def find_spec(name: str, *args: Any) -> importlib.machinery.ModuleSpec | None:
        assert name == "pyconnect_generated"
        return importlib.machinery.ModuleSpec(name, None, origin=str(origin))

    monkeypatch.setattr(build.importlib.util, "find_spec", find_spec)
    assert default_out_dir() == site.resolve()
